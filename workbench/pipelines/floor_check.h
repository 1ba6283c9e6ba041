// `dataset floors`: the detector's floor stage measured against a dataset's
// known floors. Every frame whose pose the detector estimates (imported real
// scans with a label frame; with `all_frames`, generated frames too) is
// given to EstimateFloor without its pose, and the plane found is compared
// with the frame's true floor: right, none, the ceiling, a wall, or another
// plane (a table top, a tilted fit).
//
//   FloorCheck check = CheckFloors("nyu.db", DetectorOptions{}.floor, {});
//   std::cout << FloorCheckText(check);
#pragma once

#include <string>
#include <vector>

#include "core/geometry/floor.h"
#include "core/util/enum_text.h"

namespace furn {

enum class FloorOutcome { kRight, kNone, kCeiling, kWall, kOtherPlane };

template <>
struct EnumText<FloorOutcome> {
  static constexpr const char* kKind = "floor outcome";
  static constexpr EnumEntry<FloorOutcome> kEntries[] = {
      {FloorOutcome::kRight, "right"},
      {FloorOutcome::kNone, "none"},
      {FloorOutcome::kCeiling, "ceiling"},
      {FloorOutcome::kWall, "wall"},
      {FloorOutcome::kOtherPlane, "other-plane"},
  };
};

struct FloorCheckOptions {
  double max_angle_deg = 5;    // a found floor is right within this tilt of the true one ...
  double max_height_m = 0.10;  // ... and this error of the camera's height
  double search_range_m = kFloorSearchRangeM;
  bool all_frames = false;  // also frames whose pose is known (generated)
  int max_frames = 0;       // 0: all

  void Check() const;
};

struct FloorCheckFrame {
  int64_t frame_id = 0;
  std::string name;  // the real scan's id, or "frame N"
  FloorOutcome outcome = FloorOutcome::kNone;
  double angle_deg = 0;       // between the found floor's up and the true up
  double height_error_m = 0;  // found camera height - true height
  std::string message;        // why none was found
};

struct FloorCheck {
  std::vector<FloorCheckFrame> frames;
  int Count(FloorOutcome outcome) const;
};

FloorCheck CheckFloors(const std::string& db_path,
                       const FloorOptions& floor,
                       const FloorCheckOptions& options);
std::string FloorCheckText(const FloorCheck& check);
std::string FloorCheckJson(const FloorCheck& check);

}  // namespace furn
