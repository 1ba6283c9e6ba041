#include "reports/confusion.h"

#include <algorithm>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/file_util.h"
#include "reports/png_file.h"

namespace furn {
namespace {

constexpr int kCell = 70, kTop = 70;  // px: a cell's side, the header's height

void Text(cv::Mat& image,
          const std::string& text,
          cv::Point at,
          double scale,
          cv::Scalar colour = cv::Scalar(0, 0, 0)) {
  cv::putText(image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

int TextWidth(const std::string& text, double scale) {
  int baseline = 0;
  return cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline).width;
}

// One cell: shaded by its share of the row (green on the diagonal, red
// off it), the count and the share as text.
void DrawCell(cv::Mat& image, const cv::Rect& cell, int64_t count, double share, bool diagonal) {
  const int shade = static_cast<int>(255 * (1 - share));
  cv::rectangle(image,
                cell,
                diagonal ? cv::Scalar(shade, 255, shade) : cv::Scalar(shade, shade, 255),
                cv::FILLED);
  Text(image, std::to_string(count), cv::Point(cell.x + 8, cell.y + 30), 0.5);
  char text[32];
  std::snprintf(text, sizeof(text), "%.0f%%", 100 * share);
  Text(image, text, cv::Point(cell.x + 8, cell.y + 52), 0.4, cv::Scalar(60, 60, 60));
}

}  // namespace

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
    left = std::max(left, TextWidth(row_labels[k], 0.45) + 16);
  }
  const int kLeft = std::min(left, 640);                    // longer labels are cut at the cells
  const int width = std::max(kLeft + n * kCell + 20, 560);  // room for the title
  cv::Mat image(kTop + n * kCell + 20, width, CV_8UC3, cv::Scalar(255, 255, 255));
  Text(image, title + " (rows: true, columns: predicted)", cv::Point(10, 24), 0.55);
  for (int r = 0; r < n; ++r) {
    int64_t row_total = 0;
    for (int64_t c : counts[r]) row_total += c;
    cv::Mat label_area = image(cv::Rect(0, kTop + r * kCell, kLeft - 4, kCell));
    Text(label_area, row_labels[r], cv::Point(6, kCell / 2 + 5), 0.45);
    // A column label wider than its cell ("background") is drawn smaller, not cut.
    Text(image,
         column_labels[r],
         cv::Point(kLeft + r * kCell + 4, kTop - 8),
         0.4 * std::min(1.0, (kCell - 8) / static_cast<double>(TextWidth(column_labels[r], 0.4))));
    for (int c = 0; c < n; ++c) {
      const double share = row_total > 0 ? static_cast<double>(counts[r][c]) / row_total : 0;
      DrawCell(image,
               cv::Rect(kLeft + c * kCell, kTop + r * kCell, kCell - 2, kCell - 2),
               counts[r][c],
               share,
               r == c);
    }
  }
  WritePngAtomically(image, png_path);
}

}  // namespace furn
