// Internal to reports/: encode an image as PNG and write it atomically, with
// errors that name the file; drawing helpers shared by the figures. (Kept out of public headers so
// users of the reports layer do not pull in OpenCV.)
#pragma once

#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/model/furniture_class.h"

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

// Labels of one figure that do not cover each other: a label that would
// overlap one already drawn moves down, then up, by a line at a time (at
// most kMaxShift lines); one with no free place within that is left out
// and counted. Draw the labels that matter most first.
class LabelLayout {
 public:
  static constexpr int kMaxShift = 4;

  explicit LabelLayout(cv::Mat* image) : image_(image) {}
  // Whether the label was drawn.
  bool Draw(const std::string& text, cv::Point at, const cv::Scalar& colour, double scale = 0.4);
  int left_out() const { return left_out_; }

 private:
  cv::Mat* image_;
  std::vector<cv::Rect> placed_;
  int left_out_ = 0;
};

}  // namespace furn
