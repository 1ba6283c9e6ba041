// Detections that any program wrote for the frames of a dataset, read for
// `workbench evaluate --detections` (issue 73), and written by `evaluate
// --write-detections` so the project's own runs can be scored elsewhere.
//
// Format "furnidet-detections", version 1 (docs/evaluation.md, "Scoring
// another detector"): JSON lines, one line per dataset frame,
//
//   {"format": "furnidet-detections", "version": 1, "frame": 12,
//    "detector": "my-net", "time_ms": 31.5,
//    "detections": [{"class": "chair", "score": 0.91, "centre": [x, y, z],
//                    "size": [front, left, up], "yaw": 0.3}]}
//
// boxes in the dataset's world frame (floor z = 0, z up, metres, radians;
// REP 103: the box's x axis is the object's front, yaw of that axis about z).
// Optional per detection: "floor_point" [x, y] (where the detector puts the
// object's floor reference; default the box centre's x, y), "symmetry" (1, 2
// or 4: the yaw error is taken modulo it; default the class's), "model" (the
// CAD model id it names), "size_source" ("network": the detector's own
// estimate of the footprint, the default; "model" or "class": not scored as
// one). "detector" and "time_ms" are optional per line.
//
// The project's own `detect --db D --frame F --out FILE` output (detection
// JSON format 2, indented or one line, "dataset_frame" naming the frame) is
// read as well; detections found on an estimated floor come with the pose
// they were found in, and move to the labels' frame.
//
//   const ExternalDetections read = ReadExternalDetections("dets.jsonl");
//   for (const auto& [frame, detections] : read.frames) ...
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "reports/evaluation.h"  // ScoredDetection

namespace furn {

inline constexpr const char* kExternalDetectionsFormat = "furnidet-detections";
inline constexpr int kExternalDetectionsVersion = 1;

struct ExternalFrame {
  std::vector<ScoredDetection> detections;
  std::optional<double> time_ms;  // the detector's time for the frame, if given
  // Detect output found on an estimated floor: the camera's pose in the
  // floor frame the detections are in (they move to the labels' frame).
  std::optional<Eigen::Isometry3d> detector_world_from_camera;
  std::string where;  // "file:line", for messages
};

struct ExternalDetections {
  std::map<int64_t, ExternalFrame> frames;  // by dataset frame id
  std::string detector;                     // the first line's "detector" (or "furnidet ...")
  std::vector<std::string> files;           // read, in order
  std::string content_hash;                 // of every file's bytes, in order
};

// A file of JSON lines (or one JSON object: a `detect --out` of one frame),
// or a directory of such files (*.jsonl and *.json, by name). Throws
// InputError with one line naming the file, the line and the field for
// anything malformed: not JSON, another format or a newer version, a frame
// twice, an unknown class, a number that is not finite, a negative size.
ExternalDetections ReadExternalDetections(const std::string& path);

// One line of the format for a frame's detections (ends with a newline).
// Every field is written, so reading it back scores the same.
std::string ExternalDetectionsLine(int64_t frame_id,
                                   const std::vector<ScoredDetection>& detections,
                                   const std::string& detector,
                                   std::optional<double> time_ms);

// A scored detection's fields from its box alone (what an external detector
// gives): floor point = the box centre's x, y, the CAD yaw of the REP 103
// yaw, the footprint from the size, the class's symmetry.
ScoredDetection ScoredDetectionOfBox(FurnitureClass furniture_class,
                                     double score,
                                     const OrientedBox& box);

}  // namespace furn
