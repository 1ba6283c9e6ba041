#include "workbench/pipelines/floor_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/util/error.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "workbench/formats/real_labels.h"
#include "workbench/formats/scan_file.h"

namespace furn {

void FloorCheckOptions::Check() const {
  Require(max_angle_deg > 0 && max_angle_deg < 90,
          "floors: max angle " + std::to_string(max_angle_deg) + " must be in (0, 90) degrees");
  Require(max_height_m > 0, "floors: max height error must be > 0 m");
  Require(search_range_m > 0, "floors: search range must be > 0 m");
  Require(max_frames >= 0, "floors: --frames must be >= 0");
}

int FloorCheck::Count(FloorOutcome outcome) const {
  return static_cast<int>(
      std::count_if(frames.begin(), frames.end(), [&](const FloorCheckFrame& f) {
        return f.outcome == outcome;
      }));
}

namespace {

// The real scans' names by frame id, from the dataset's generation options.
std::map<int64_t, std::string> ScanNames(const std::string& generation_options) {
  std::map<int64_t, std::string> names;
  const nlohmann::json json = nlohmann::json::parse(generation_options, nullptr, false);
  if (!json.is_object() || !json.contains("frames") || !json["frames"].is_array()) return names;
  for (const nlohmann::json& frame : json["frames"]) {
    if (frame.is_object() && frame.contains("frame") && frame["frame"].is_number_integer() &&
        frame.contains("id") && frame["id"].is_string())
      names[frame["frame"].get<int64_t>()] = frame["id"].get<std::string>();
  }
  return names;
}

// The frames to check: those whose pose the detector estimates, or all.
std::vector<int64_t> FramesToCheck(DatasetDb& db, const FloorCheckOptions& options) {
  const std::set<int64_t> estimated = FramesWithEstimatedPose(db.GenerationOptions().value_or(""));
  std::vector<int64_t> frames;
  for (int64_t room_id : db.RoomIds()) {
    for (const FrameRecord& frame : db.ReadRoom(room_id, /*with_images=*/false).frames) {
      if (options.all_frames || estimated.count(frame.id)) frames.push_back(frame.id);
    }
  }
  if (options.max_frames > 0 && static_cast<int>(frames.size()) > options.max_frames)
    frames.resize(static_cast<size_t>(options.max_frames));
  return frames;
}

// The found floor against the true one: the angle between their up
// directions (in the camera's frame) and the camera heights.
FloorCheckFrame Compare(const FloorEstimate& found,
                        const Eigen::Isometry3d& truth,
                        const FloorCheckOptions& options) {
  FloorCheckFrame frame;
  if (!found.found) {
    frame.outcome = FloorOutcome::kNone;
    frame.message = found.message;
    return frame;
  }
  // World z seen from the camera: the rotation's last row.
  const Eigen::Vector3d true_up = truth.linear().row(2).transpose();
  const Eigen::Vector3d found_up = found.world_from_camera.linear().row(2).transpose();
  const double cosine = std::clamp(true_up.dot(found_up), -1.0, 1.0);
  frame.angle_deg = std::acos(cosine) * 180 / M_PI;
  frame.height_error_m = found.world_from_camera.translation().z() - truth.translation().z();
  if (cosine < -0.5) {
    frame.outcome = FloorOutcome::kCeiling;
  } else if (cosine < 0.5) {
    frame.outcome = FloorOutcome::kWall;
  } else if (frame.angle_deg <= options.max_angle_deg &&
             std::abs(frame.height_error_m) <= options.max_height_m) {
    frame.outcome = FloorOutcome::kRight;
  } else {
    frame.outcome = FloorOutcome::kOtherPlane;
  }
  return frame;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace

FloorCheck CheckFloors(const std::string& db_path,
                       const FloorOptions& floor,
                       const FloorCheckOptions& options) {
  floor.Check();
  options.Check();
  DatasetDb db(db_path, DatasetDb::Mode::kReadOnly);
  const std::map<int64_t, std::string> names = ScanNames(db.GenerationOptions().value_or(""));
  const std::vector<int64_t> frame_ids = FramesToCheck(db, options);
  Require(!frame_ids.empty(),
          db_path +
              ": no frame whose floor the detector estimates (a generated dataset: "
              "give --all-frames)");
  FloorCheck check;
  Progress progress("floors", frame_ids.size(), "frames");
  for (int64_t frame_id : frame_ids) {
    ScanSource source;
    source.db_path = db_path;
    source.frame_id = frame_id;
    const LoadedScan scan = LoadScan(source);
    // A generated frame's pose is given to the detector; the check hides it.
    const Eigen::Isometry3d truth = scan.label_from_camera.value_or(
        scan.input.world_from_camera.value_or(Eigen::Isometry3d::Identity()));
    FloorCheckFrame frame =
        Compare(EstimateFloor(scan.input.points, floor, options.search_range_m), truth, options);
    frame.frame_id = frame_id;
    frame.name = names.count(frame_id) ? names.at(frame_id) : "frame " + std::to_string(frame_id);
    check.frames.push_back(std::move(frame));
    progress.Advance();
  }
  progress.Finish();
  return check;
}

std::string FloorCheckText(const FloorCheck& check) {
  std::ostringstream text;
  const int n = static_cast<int>(check.frames.size());
  char line[160];
  std::snprintf(line,
                sizeof line,
                "floors of %d frames: %d right (%.1f %%)",
                n,
                check.Count(FloorOutcome::kRight),
                n ? 100.0 * check.Count(FloorOutcome::kRight) / n : 0.0);
  text << line;
  for (FloorOutcome outcome : {FloorOutcome::kNone,
                               FloorOutcome::kCeiling,
                               FloorOutcome::kWall,
                               FloorOutcome::kOtherPlane}) {
    text << ", " << check.Count(outcome) << " " << EnumName(outcome);
  }
  std::vector<double> angles, heights;
  for (const FloorCheckFrame& f : check.frames) {
    if (f.outcome == FloorOutcome::kRight) {
      angles.push_back(f.angle_deg);
      heights.push_back(std::abs(f.height_error_m));
    }
  }
  std::snprintf(line,
                sizeof line,
                "\nright floors: median tilt error %.2f deg, median height error %.3f m\n",
                Median(angles),
                Median(heights));
  text << line;
  for (const FloorCheckFrame& f : check.frames) {
    if (f.outcome == FloorOutcome::kRight) continue;
    std::snprintf(line, sizeof line, "  %-24s %-12s", f.name.c_str(), EnumName(f.outcome));
    text << line;
    if (f.outcome == FloorOutcome::kNone) {
      text << f.message << "\n";
    } else {
      std::snprintf(
          line, sizeof line, "tilt %.1f deg, height %+.2f m\n", f.angle_deg, f.height_error_m);
      text << line;
    }
  }
  return text.str();
}

std::string FloorCheckJson(const FloorCheck& check) {
  nlohmann::ordered_json counts;
  for (const auto& entry : EnumText<FloorOutcome>::kEntries)
    counts[entry.name] = check.Count(entry.value);
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  for (const FloorCheckFrame& f : check.frames) {
    frames.push_back({{"frame", f.frame_id},
                      {"name", f.name},
                      {"outcome", EnumName(f.outcome)},
                      {"angle_deg", f.angle_deg},
                      {"height_error_m", f.height_error_m},
                      {"message", f.message}});
  }
  return nlohmann::ordered_json{{"frames", static_cast<int>(check.frames.size())},
                                {"counts", counts},
                                {"per_frame", frames}}
             .dump(1, ' ', false, nlohmann::json::error_handler_t::replace) +
         "\n";
}

}  // namespace furn
