// Dataset splits: every room is in train, val or test (SplitForSeed); a
// selection of frames (an evaluation, a run, an export) names one of them or
// all.
//
//   Split s = ParseSplit("val", "--split");   // Split::kVal
//   EnumName(s);                              // "val"
#pragma once

#include <string>

#include "core/util/enum_text.h"

namespace furn {

enum class Split { kTrain, kVal, kTest, kAll };

template <>
struct EnumText<Split> {
  static constexpr const char* kKind = "split";
  static constexpr EnumEntry<Split> kEntries[] = {
      {Split::kTrain, "train"}, {Split::kVal, "val"}, {Split::kTest, "test"}, {Split::kAll, "all"}};
};

// Whether a room of split `room` is in the selection `selected`.
inline bool InSplit(Split room, Split selected) {
  return selected == Split::kAll || room == selected;
}

// Throws InputError "<what> 'X' must be train, val, test or all" (a room's
// split may not be 'all': allow_all false gives "must be train, val or test").
Split ParseSplit(const std::string& text, const std::string& what = "split", bool allow_all = true);

}  // namespace furn
