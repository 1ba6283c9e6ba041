#include "reports/confusion.h"

#include <algorithm>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
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

// Short labels head the columns; when any label is long (CAD model ids) the
// rows are numbered "k. label" and the numbers head the columns.
struct Headings {
  std::vector<std::string> rows, columns;
};
Headings MakeHeadings(const std::vector<std::string>& row_labels,
                      const std::vector<std::string>& column_labels) {
  auto long_label = [](const std::string& l) { return l.size() > 12; };
  const bool numbered = std::any_of(row_labels.begin(), row_labels.end(), long_label) ||
                        std::any_of(column_labels.begin(), column_labels.end(), long_label);
  Headings headings{row_labels, column_labels};
  if (!numbered) return headings;
  for (size_t k = 0; k < row_labels.size(); ++k)
    headings.rows[k] = std::to_string(k + 1) + ". " + row_labels[k];
  for (size_t k = 0; k < column_labels.size(); ++k) {
    const auto same = std::find(row_labels.begin(), row_labels.end(), column_labels[k]);
    headings.columns[k] = same != row_labels.end() ? std::to_string(same - row_labels.begin() + 1)
                                                   : column_labels[k].substr(0, 8);
  }
  return headings;
}

}  // namespace

void WriteConfusionPng(const std::vector<std::string>& row_labels,
                       const std::vector<std::string>& column_labels,
                       const std::vector<std::vector<int64_t>>& counts,
                       const std::string& title,
                       const std::string& png_path) {
  const int rows = static_cast<int>(row_labels.size());
  const int columns = static_cast<int>(column_labels.size());
  const std::string shape = png_path + ": the confusion needs " + std::to_string(rows) +
                            " rows of " + std::to_string(columns) + " counts";
  Require(rows > 0 && columns > 0 && static_cast<int>(counts.size()) == rows, shape);
  for (const auto& row : counts) Require(static_cast<int>(row.size()) == columns, shape);
  Require(FileExtension(png_path) == "png", png_path + ": the confusion matrix is written as .png");
  const Headings headings = MakeHeadings(row_labels, column_labels);
  int left = 110;
  for (const std::string& label : headings.rows) left = std::max(left, TextWidth(label, 0.45) + 16);
  const int kLeft = std::min(left, 640);  // longer labels are cut
  const std::string heading = title + " (rows: true, columns: predicted)";
  const int width = std::max(kLeft + columns * kCell + 20, TextWidth(heading, 0.55) + 20);
  cv::Mat image(kTop + rows * kCell + 20, width, CV_8UC3, cv::Scalar(255, 255, 255));
  Text(image, heading, cv::Point(10, 24), 0.55);
  for (int c = 0; c < columns; ++c) {  // a label wider than its cell is drawn smaller, not cut
    const std::string& label = headings.columns[c];
    Text(image,
         label,
         cv::Point(kLeft + c * kCell + 4, kTop - 8),
         0.4 * std::min(1.0, (kCell - 8) / static_cast<double>(TextWidth(label, 0.4))));
  }
  for (int r = 0; r < rows; ++r) {
    int64_t row_total = 0;
    for (int64_t n : counts[r]) row_total += n;
    cv::Mat label_area = image(cv::Rect(0, kTop + r * kCell, kLeft - 4, kCell));
    Text(label_area, headings.rows[r], cv::Point(6, kCell / 2 + 5), 0.45);
    for (int c = 0; c < columns; ++c) {
      if (row_labels[r] == "background" && column_labels[c] == "missed") {  // cannot happen
        cv::rectangle(image,
                      cv::Rect(kLeft + c * kCell, kTop + r * kCell, kCell - 2, kCell - 2),
                      cv::Scalar(235, 235, 235),
                      cv::FILLED);
        continue;
      }
      const double share = row_total > 0 ? static_cast<double>(counts[r][c]) / row_total : 0;
      DrawCell(image,
               cv::Rect(kLeft + c * kCell, kTop + r * kCell, kCell - 2, kCell - 2),
               counts[r][c],
               share,
               row_labels[r] == column_labels[c]);
    }
  }
  WritePngAtomically(image, png_path);
}

void WriteConfusionPng(const std::vector<std::string>& labels,
                       const std::vector<std::vector<int64_t>>& counts,
                       const std::string& title,
                       const std::string& png_path) {
  WriteConfusionPng(labels, labels, counts, title, png_path);
}

}  // namespace furn
