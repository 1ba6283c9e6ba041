// `workbench detect`: one scan in (a PCD/PLY cloud, a depth PNG with
// intrinsics, or a frame of a dataset DB), detections out as JSON, and an
// optional debug directory of PNGs.
//
//   ScanSource source;
//   source.db_path = "synth.db"; source.frame_id = 12;
//   LoadedScan scan = LoadScan(source);
//   DetectionResult result = detector.Detect(scan.input, /*keep_debug=*/true);
//   WriteFileAtomically("det.json", DetectionJson(result, scan));
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/detector.h"
#include "db/dataset_db.h"
#include "renderers/camera.h"
#include "reports/detection_debug.h"

namespace furn {

struct ScanSource {
  std::string cloud_path;              // .pcd or .ply
  std::string depth_path;              // 16-bit depth PNG
  std::string intrinsics = "kinect1";  // kinect1, or fx,fy,cx,cy (size from the image)
  double depth_scale = 1000;           // depth units per metre (TUM: 5000)
  std::string db_path;                 // dataset database ...
  int64_t frame_id = -1;               // ... and one of its frames
};

struct LoadedScan {
  DetectionInput input;
  std::string description;  // for messages and the JSON
  CameraIntrinsics camera;  // of the depth image or DB frame; Kinect v1 for clouds
  std::vector<GroundTruthFootprint> ground_truth;  // DB frames only
};

// Exactly one of cloud, depth or db must be given. Throws InputError naming
// the file or value for anything unreadable or inconsistent.
LoadedScan LoadScan(const ScanSource& source);

// The intrinsics a dataset frame was rendered with.
CameraIntrinsics IntrinsicsOf(const FrameRecord& frame);

// Detection input of a dataset frame: its noisy depth back-projected, with
// its known pose. `what` names the frame in errors.
DetectionInput DetectionInputOf(const FrameRecord& frame, const std::string& what);

// "kinect1" or "fx,fy,cx,cy" for an image of width x height.
CameraIntrinsics ParseIntrinsics(const std::string& text, int width, int height);

// Detections, pose used, timings, as JSON text.
std::string DetectionJson(const DetectionResult& result, const LoadedScan& scan);

}  // namespace furn
