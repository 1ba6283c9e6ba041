// A scan to detect in, from any source: a PCD/PLY cloud (camera or world
// frame), a depth image with intrinsics or a camera file, or a frame of a
// dataset DB; the detector's input, its camera pose and its ground truth.
//
//   ScanSource source;
//   source.db_path = "synth.db"; source.frame_id = 12;
//   LoadedScan scan = LoadScan(source);
//   DetectionResult result = detector.Detect(scan.input);
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/detector/detector.h"
#include "core/geometry/scan_fusion.h"
#include "core/model/furniture_box.h"
#include "db/dataset_db.h"
#include "renderers/camera.h"
#include "workbench/formats/dataset_frame.h"  // FrameFusion

namespace furn {

struct ScanSource {
  std::string cloud_path;              // .pcd or .ply
  std::string depth_path;              // depth image (ReadDepthImage's formats)
  std::string intrinsics = "kinect1";  // kinect1, or fx,fy,cx,cy (size from the image)
  std::string camera_file;             // or a camera file (ReadCameraFile), instead
  std::optional<int64_t> image_id;     // the entry of a BOP scene_camera.json
  // Depth units per metre; 0: the camera file's, else 1000 for 16-bit images
  // (millimetres) and 1 for float images (metres). TUM: 5000.
  double depth_scale = 0;
  std::string db_path;    // dataset database ...
  int64_t frame_id = -1;  // ... and one of its frames
  FrameFusion fusion;     // ... detected with its room's other frames fused in

  // Clouds in a world frame rather than the camera's: the camera's pose in
  // it (ParsePose's text), else the PCD's VIEWPOINT. With floor_aligned the
  // world frame is the detector's (z up, floor at z = 0) and the pose is used
  // as it is; otherwise the floor is found as for camera-frame clouds.
  // A floor-aligned cloud without a pose: an organised cloud's camera is
  // estimated from its pixel grid (CameraOfOrganisedCloud); an unorganised
  // one needs `sensor` (x,y,z).
  std::string world_from_camera;
  bool floor_aligned = false;
  std::string sensor;
};

struct LoadedScan {
  DetectionInput input;
  std::string description;  // for messages and the JSON
  CameraIntrinsics camera;  // of the depth image or DB frame; Kinect v1 for clouds
  // Where `camera` came from: "kinect1" (the default or --intrinsics
  // kinect1), "intrinsics" (fx,fy,cx,cy given), "camera file", "dataset
  // frame", "CameraInfo", "organised cloud"; empty: none (an unorganised
  // cloud: `camera` only draws the debug views).
  std::string camera_source;
  std::vector<GroundTruthFootprint> ground_truth;  // DB frames only
  int64_t dataset_frame = -1;  // a DB frame's id (its detections name it), else -1
  std::string pose_source;     // where the pose came from, or empty (floor estimated)
  // Imported real scans whose floor the detector estimates: the camera's pose
  // in the labels' frame (ground_truth is in it, detections are not).
  std::optional<Eigen::Isometry3d> label_from_camera;
};

// The kinds of scan a ScanSource can name, one row each (ScanKinds(), in
// scan_file.cc). A new kind is a path field of ScanSource, a loader and a row
// (its flag, the file extensions that name it as an input, what pose options
// it takes), plus its flag in workbench/cli/run_detect.cc: LoadScan, the
// inputs' expansion (scan_inputs.cc), the batch test and the messages follow
// the table.
struct ScanKind {
  const char* name;                     // "cloud"
  const char* flag;                     // "--cloud"
  std::string ScanSource::*path;        // the field that names the scan
  std::vector<std::string> extensions;  // lower case, no dot; empty: never an input file
  bool takes_world_pose = false;        // --world-from-camera, --floor-aligned
  bool takes_sensor = false;            // --sensor
  LoadedScan (*load)(const ScanSource& source) = nullptr;
};
const std::vector<ScanKind>& ScanKinds();

// The kind whose path field `source` sets; throws InputError unless exactly
// one is set.
const ScanKind& KindOf(const ScanSource& source);
// The kind whose extensions include the file's, or none.
const ScanKind* KindOfFile(const std::string& path);
// Whether any kind's path is set; `source` with every kind's path cleared.
bool NamesAScan(const ScanSource& source);
ScanSource WithoutScan(ScanSource source);

// Exactly one kind's path must be given. Throws InputError naming the file
// or value for anything unreadable or inconsistent.
LoadedScan LoadScan(const ScanSource& source);

// The scan's ground truth in the detector's floor frame: as stored, or moved
// there from the labels' frame of an imported real scan.
std::vector<GroundTruthFootprint> GroundTruthInDetectorFrame(const LoadedScan& scan,
                                                             const DetectionResult& result);

// Several scans with their own poses (world-frame clouds) as one: every
// scan's points in the last one's camera (FuseScans), their poses first
// refined against it by `registration` when given (RegisterScans); its
// camera, its pose source and a description naming them all. Throws
// InputError naming the first scan without a pose in a floor-aligned frame.
LoadedScan FuseLoadedScans(const std::vector<LoadedScan>& scans,
                           const std::optional<ScanRegistrationOptions>& registration);

// "kinect1" or "fx,fy,cx,cy" for an image of width x height.
CameraIntrinsics ParseIntrinsics(const std::string& text, int width, int height);

// The scan a source names (its file, or db and frame), for messages.
std::string ScanSourceName(const ScanSource& source);
}  // namespace furn
