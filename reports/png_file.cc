#include "reports/png_file.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"
#include "core/file_util.h"
#include "reports/class_colours.h"

namespace furn {

void WritePngAtomically(const cv::Mat& image, const std::string& png_path) {
  std::vector<uchar> bytes;
  Require(cv::imencode(".png", image, bytes), png_path + ": PNG encoding failed");
  WriteFileAtomically(png_path, std::string(bytes.begin(), bytes.end()));
}

std::array<uint8_t, 3> ClassColourRgb(const std::string& name) {
  if (name == "chair") return {60, 220, 60};
  if (name == "armchair") return {40, 160, 255};
  if (name == "table") return {255, 200, 40};
  if (name == "sideboard") return {230, 80, 230};
  return {255, 255, 255};
}

cv::Scalar ClassColour(const std::string& name) {
  const std::array<uint8_t, 3> rgb = ClassColourRgb(name);
  return cv::Scalar(rgb[2], rgb[1], rgb[0]);  // OpenCV's BGR
}

void DrawLabel(
    cv::Mat* image, const std::string& text, cv::Point at, const cv::Scalar& colour, double scale) {
  cv::putText(
      *image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(*image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

}  // namespace furn
