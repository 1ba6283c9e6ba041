// Internal to reports/: encode an image as PNG and write it atomically, with
// errors that name the file; drawing helpers shared by the figures. (Kept out of public headers so
// users of the reports layer do not pull in OpenCV.)
#pragma once

#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>

#include "core/furniture_class.h"

namespace furn {

void WritePngAtomically(const cv::Mat& image, const std::string& png_path);

// One colour per detector class (BGR), white for none (clutter).
cv::Scalar ClassColour(std::optional<FurnitureClass> furniture_class);

// Text with a dark outline, readable on any background.
void DrawLabel(cv::Mat* image,
               const std::string& text,
               cv::Point at,
               const cv::Scalar& colour,
               double scale = 0.4);

}  // namespace furn
