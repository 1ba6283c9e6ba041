// A confusion matrix as a PNG heat map with counts and row-normalised shades.
//
//   WriteConfusionPng({"chair", "table"}, {{40, 2}, {5, 30}}, "category", "confusion.png");
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace furn {

// rows: true label, columns: predicted label. Throws InputError for a
// non-square matrix or a bad path.
void WriteConfusionPng(const std::vector<std::string>& labels,
                       const std::vector<std::vector<int64_t>>& counts,
                       const std::string& title,
                       const std::string& png_path);

}  // namespace furn
