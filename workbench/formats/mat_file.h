// Numeric arrays from a MATLAB level-5 MAT-file (MATLAB 5.0 to 7.2, the
// default before -v7.3): the format NYU Depth V2 ships its official
// train/test split in (`splits.mat`: trainNdxs, testNdxs). Only what such
// files hold is read: real numeric matrices, zlib-compressed or not; cells,
// structs, sparse and complex arrays are skipped by name, never parsed.
//
//   MatArrays arrays = ReadMatFile("splits.mat");
//   const std::vector<double>& train = arrays.at("trainNdxs").values;
//
// The file is data: sizes come from its tags and are checked against the
// bytes that are there (no allocation a header merely claims), compressed
// elements inflate to at most kMaxMatElementBytes, and anything malformed
// throws InputError naming the file, the variable and the rule.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace furn {

// A MAT-file larger than this is refused (the split file is 2.6 KB).
inline constexpr uint64_t kMaxMatFileBytes = uint64_t{64} << 20;
// One compressed element may inflate to at most this.
inline constexpr uint64_t kMaxMatElementBytes = uint64_t{256} << 20;

struct MatArray {
  std::vector<int64_t> dimensions;  // MATLAB's, column-major
  std::vector<double> values;       // column-major, converted from the stored type
};

using MatArrays = std::map<std::string, MatArray>;

MatArrays ReadMatFile(const std::string& path);
// The same from bytes; `what` names them in errors.
MatArrays ParseMatFile(const std::string& bytes, const std::string& what);

}  // namespace furn
