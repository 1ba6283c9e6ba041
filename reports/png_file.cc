#include "reports/png_file.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/class_colours.h"

namespace furn {

void WritePngAtomically(const cv::Mat& image, const std::string& png_path) {
  std::vector<uchar> bytes;
  Require(cv::imencode(".png", image, bytes), png_path + ": PNG encoding failed");
  WriteFileAtomically(png_path, std::string(bytes.begin(), bytes.end()));
}

std::array<uint8_t, 3> ClassColourRgb(std::optional<FurnitureClass> furniture_class) {
  if (!furniture_class) return {255, 255, 255};
  switch (*furniture_class) {
    case FurnitureClass::kChair:
      return {60, 220, 60};
    case FurnitureClass::kArmchair:
      return {40, 160, 255};
    case FurnitureClass::kTable:
      return {255, 200, 40};
    case FurnitureClass::kSideboard:
      return {230, 80, 230};
    case FurnitureClass::kSofa:  // teal: far from the red of missed objects
      return {0, 200, 190};
  }
  return {255, 255, 255};
}

cv::Scalar ClassColour(std::optional<FurnitureClass> furniture_class) {
  const std::array<uint8_t, 3> rgb = ClassColourRgb(furniture_class);
  return cv::Scalar(rgb[2], rgb[1], rgb[0]);  // OpenCV's BGR
}

namespace {

// Where a label's text starts and the box it covers (outline included),
// kept inside the image: a label at an edge moves in rather than being cut.
std::pair<cv::Point, cv::Rect> LabelPlace(const cv::Mat& image,
                                          const std::string& text,
                                          cv::Point at,
                                          double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 3, &baseline);
  at.x = std::max(2, std::min(at.x, image.cols - size.width - 2));
  at.y = std::max(size.height + 2, std::min(at.y, image.rows - baseline - 2));
  return {at,
          cv::Rect(at.x - 1, at.y - size.height - 1, size.width + 2, size.height + baseline + 2)};
}

void PutLabel(
    cv::Mat* image, const std::string& text, cv::Point at, const cv::Scalar& colour, double scale) {
  cv::putText(
      *image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(*image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

}  // namespace

void DrawLabel(
    cv::Mat* image, const std::string& text, cv::Point at, const cv::Scalar& colour, double scale) {
  PutLabel(image, text, LabelPlace(*image, text, at, scale).first, colour, scale);
}

bool LabelLayout::Draw(const std::string& text,
                       cv::Point at,
                       const cv::Scalar& colour,
                       double scale) {
  const int line = LabelPlace(*image_, text, at, scale).second.height;
  for (int step = 0; step <= 2 * kMaxShift; ++step) {
    // 0, +1, -1, +2, -2, ... lines
    const int lines = (step + 1) / 2 * (step % 2 == 1 ? 1 : -1);
    const auto [start, box] = LabelPlace(*image_, text, at + cv::Point(0, lines * line), scale);
    const bool free = std::none_of(
        placed_.begin(), placed_.end(), [&](const cv::Rect& r) { return (r & box).area() > 0; });
    if (!free) continue;
    placed_.push_back(box);
    PutLabel(image_, text, start, colour, scale);
    return true;
  }
  ++left_out_;
  return false;
}

}  // namespace furn
