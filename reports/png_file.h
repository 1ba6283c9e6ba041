// Internal to reports/: encode an image as PNG and write it atomically, with
// errors that name the file; drawing helpers shared by the figures. (Kept out of public headers so
// users of the reports layer do not pull in OpenCV.)
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>

namespace furn {

void WritePngAtomically(const cv::Mat& image, const std::string& png_path);

// One colour per detector class (BGR), white for anything else.
cv::Scalar ClassColour(const std::string& class_name);

// Text with a dark outline, readable on any background.
void DrawLabel(cv::Mat* image,
               const std::string& text,
               cv::Point at,
               const cv::Scalar& colour,
               double scale = 0.4);

}  // namespace furn
