// A confusion matrix as a PNG heat map with counts and row-normalised shades.
//
//   WriteConfusionPng({"chair", "table"}, {{40, 2}, {5, 30}}, "category", "confusion.png");
//   WriteConfusionPng({"chair", "background"}, {"chair", "missed"}, {{40, 3}, {6, 0}}, ...);
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace furn {

// rows: true label, columns: predicted label; a cell whose row and column
// say the same is a hit (green), any other a confusion (red). Throws
// InputError for counts of another shape or a bad path.
void WriteConfusionPng(const std::vector<std::string>& row_labels,
                       const std::vector<std::string>& column_labels,
                       const std::vector<std::vector<int64_t>>& counts,
                       const std::string& title,
                       const std::string& png_path);

// The square case: the same labels on both sides.
void WriteConfusionPng(const std::vector<std::string>& labels,
                       const std::vector<std::vector<int64_t>>& counts,
                       const std::string& title,
                       const std::string& png_path);

}  // namespace furn
