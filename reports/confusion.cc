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
  // Short labels head the columns; long ones (CAD model ids) are numbered,
  // the numbers head the columns and the rows say "k. label" in full.
  const bool numbered =
      std::any_of(labels.begin(), labels.end(), [](const std::string& l) { return l.size() > 12; });
  std::vector<std::string> row_labels(labels), column_labels(labels);
  int left = 110;
  for (int k = 0; k < n; ++k) {
    if (numbered) {
      row_labels[k] = std::to_string(k + 1) + ". " + labels[k];
      column_labels[k] = std::to_string(k + 1);
    }
    int baseline = 0;
    const cv::Size size =
        cv::getTextSize(row_labels[k], cv::FONT_HERSHEY_SIMPLEX, 0.45, 1, &baseline);
    left = std::max(left, size.width + 16);
  }
  constexpr int kCell = 70, kTop = 70;
  const int kLeft = std::min(left, 640);                    // longer labels are cut at the cells
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
    cv::Mat label_area = image(cv::Rect(0, kTop + r * kCell, kLeft - 4, kCell));
    cv::putText(label_area,
                row_labels[r],
                cv::Point(6, kCell / 2 + 5),
                cv::FONT_HERSHEY_SIMPLEX,
                0.45,
                cv::Scalar(0, 0, 0),
                1,
                cv::LINE_AA);
    // A column label wider than its cell ("background") is drawn smaller, not cut.
    int baseline = 0;
    const double label_width =
        cv::getTextSize(column_labels[r], cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &baseline).width;
    cv::putText(image,
                column_labels[r],
                cv::Point(kLeft + r * kCell + 4, kTop - 8),
                cv::FONT_HERSHEY_SIMPLEX,
                0.4 * std::min(1.0, (kCell - 8) / label_width),
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
