// Internal to reports/: encode an image as PNG and write it atomically, with
// errors that name the file. (Kept out of public headers so users of the
// reports layer do not pull in OpenCV.)
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

namespace furn {

void WritePngAtomically(const cv::Mat& image, const std::string& png_path);

}  // namespace furn
