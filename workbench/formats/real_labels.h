// Labelled real scans: a small JSON file naming depth images or clouds with
// hand-made labels, imported into a dataset database so that `evaluate`,
// `report`, `history` and `regress` treat them like generated frames.
//
//   {"format": "furnidet-real-set", "version": 1,
//    "scans": [
//      {"id": "tum-fr2-desk", "depth": "tum/depth.png", "intrinsics": "525,525,319.5,239.5",
//       "depth_scale": 5000, "source": "...", "licence": "CC BY 4.0",
//       "label_frame": [16 numbers, row by row: the camera's pose in the labels' floor frame],
//       "objects": [{"class": "chair", "x": 1.9, "y": -0.4, "yaw": 1.57,
//                    "size": [0.5, 0.5, 0.9], "note": "red office chair"}]}]}
//
// A scan names exactly one of "cloud" or "depth" (paths relative to the
// file), with the options of `workbench detect` ("intrinsics", "camera",
// "depth_scale", "world_from_camera", "floor_aligned", "sensor"). Labels are
// footprint centres on the floor (z = 0, z up) in the label frame: the
// scan's own frame when it is floor-aligned, else "label_frame". "yaw" is
// null where the front is not defined (a round table); "visibility" (0..1,
// default 1) marks objects mostly out of view.
//
//   RealSet set = ReadRealSet("data/real/labels.json");
//   for (const RealScan& scan : set.scans) LoadScan(scan.source);
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "workbench/formats/scan_file.h"

namespace furn {

struct RealObject {
  FurnitureClass furniture_class = FurnitureClass::kChair;
  double x = 0, y = 0;        // footprint centre, label frame, metres
  std::optional<double> yaw;  // radians about z, the front along the model's -y
  Eigen::Vector3d size = Eigen::Vector3d(0.5, 0.5, 0.8);  // width, depth, height (m)
  double visibility = 1;
  std::string note;
};

struct RealScan {
  std::string id;
  ScanSource source;
  std::string origin, licence;
  // The camera's pose in the labels' floor frame; for floor-aligned scans
  // the pose they load with.
  std::optional<Eigen::Isometry3d> label_frame;
  std::vector<RealObject> objects;
};

struct RealSet {
  std::string path;
  std::vector<RealScan> scans;
};

// Throws InputError naming the file, the scan and the field for anything
// malformed: unknown keys, a missing input file, an unknown class, a label
// frame that is not a rigid motion, duplicate ids.
RealSet ReadRealSet(const std::string& path);

// Frames of a dataset whose pose the detector must estimate (imported real
// scans without a known floor); empty for generated datasets.
std::set<int64_t> FramesWithEstimatedPose(const std::string& generation_options_json);

}  // namespace furn
