#include "reports/confusion.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/file_util.h"
#include "reports/png_file.h"

namespace furn {

void WriteConfusionPng(const std::vector<std::string>& labels,
                       const std::vector<std::vector<int64_t>>& counts,
                       const std::string& title,
                       const std::string& png_path) {
  const int n = static_cast<int>(labels.size());
  Require(n > 0 && static_cast<int>(counts.size()) == n,
          png_path + ": confusion matrix must be square");
  for (const auto& row : counts)
    Require(static_cast<int>(row.size()) == n, png_path + ": confusion matrix must be square");
  Require(FileExtension(png_path) == "png", png_path + ": the confusion matrix is written as .png");
  constexpr int kCell = 70, kLeft = 110, kTop = 70;
  const int width = std::max(kLeft + n * kCell + 20, 560);  // room for the title
  cv::Mat image(kTop + n * kCell + 20, width, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(image,
              title + " (rows: true, columns: predicted)",
              cv::Point(10, 24),
              cv::FONT_HERSHEY_SIMPLEX,
              0.55,
              cv::Scalar(0, 0, 0),
              1,
              cv::LINE_AA);
  for (int r = 0; r < n; ++r) {
    int64_t row_total = 0;
    for (int64_t c : counts[r]) row_total += c;
    cv::putText(image,
                labels[r],
                cv::Point(6, kTop + r * kCell + kCell / 2 + 5),
                cv::FONT_HERSHEY_SIMPLEX,
                0.45,
                cv::Scalar(0, 0, 0),
                1,
                cv::LINE_AA);
    cv::putText(image,
                labels[r].substr(0, 8),
                cv::Point(kLeft + r * kCell + 4, kTop - 8),
                cv::FONT_HERSHEY_SIMPLEX,
                0.4,
                cv::Scalar(0, 0, 0),
                1,
                cv::LINE_AA);
    for (int c = 0; c < n; ++c) {
      const double share = row_total > 0 ? static_cast<double>(counts[r][c]) / row_total : 0;
      const cv::Rect cell(kLeft + c * kCell, kTop + r * kCell, kCell - 2, kCell - 2);
      const int shade = static_cast<int>(255 * (1 - share));
      cv::rectangle(image,
                    cell,
                    r == c ? cv::Scalar(shade, 255, shade) : cv::Scalar(shade, shade, 255),
                    cv::FILLED);
      char text[32];
      std::snprintf(text, sizeof(text), "%lld", static_cast<long long>(counts[r][c]));
      cv::putText(image,
                  text,
                  cv::Point(cell.x + 8, cell.y + 30),
                  cv::FONT_HERSHEY_SIMPLEX,
                  0.5,
                  cv::Scalar(0, 0, 0),
                  1,
                  cv::LINE_AA);
      std::snprintf(text, sizeof(text), "%.0f%%", 100 * share);
      cv::putText(image,
                  text,
                  cv::Point(cell.x + 8, cell.y + 52),
                  cv::FONT_HERSHEY_SIMPLEX,
                  0.4,
                  cv::Scalar(60, 60, 60),
                  1,
                  cv::LINE_AA);
    }
  }
  WritePngAtomically(image, png_path);
}

}  // namespace furn
