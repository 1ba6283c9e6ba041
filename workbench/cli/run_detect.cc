#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>
#include <vector>

#include "core/util/error.h"
#include "core/util/progress.h"
#include "core/util/text.h"
#include "renderers/camera.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/commands.h"
#include "workbench/cli/detector_flags.h"
#include "workbench/formats/scan_inputs.h"
#include "workbench/pipelines/detect_batch.h"

namespace furn {

namespace {

// Where a scan comes from and how to read it.
void AddScanFlags(CLI::App* app_pointer, ScanSource* source_pointer) {
  CLI::App& app = *app_pointer;
  ScanSource& source = *source_pointer;
  app.add_option("--cloud", source.cloud_path, "Point cloud (.pcd or .ply), camera frame, metres");
  app.add_option("--depth", source.depth_path, "Depth image (16-bit PNG/TIFF, float TIFF/EXR)");
  app.add_option("--intrinsics", source.intrinsics, "kinect1 or fx,fy,cx,cy (depth images)")
      ->capture_default_str();
  app.add_option("--camera",
                 source.camera_file,
                 "Camera file for depth images: BOP camera.json or scene_camera.json, ROS "
                 "CameraInfo YAML (instead of --intrinsics)");
  app.add_option("--depth-scale",
                 source.depth_scale,
                 "Depth units per metre (default: the camera file's, else 1000 for 16-bit "
                 "images, 1 for float; TUM: 5000)");
  app.add_option(
      "--world-from-camera",
      source.world_from_camera,
      "Cloud in a world frame: the camera's pose in it, 16 numbers (4x4, row by row) "
      "or 't=x,y,z q=qx,qy,qz,qw' (quaternion x,y,z,w as ROS writes it; default: the PCD "
      "VIEWPOINT)");
  app.add_flag("--floor-aligned",
               source.floor_aligned,
               "The world frame is floor-aligned (z up, floor at z = 0): its pose is used, the "
               "floor not searched");
  app.add_option("--sensor",
                 source.sensor,
                 "Sensor position x,y,z of a floor-aligned unorganised cloud without a pose");
}

// Detection over a ROS bag's topic.
void AddBagFlags(CLI::App* app_pointer, BagScanOptions* bag_pointer, std::string* out_bag_pointer) {
  CLI::App& app = *app_pointer;
  BagScanOptions& bag = *bag_pointer;
  std::string& out_bag = *out_bag_pointer;
  app.add_option("--bag",
                 bag.bag_path,
                 "ROS bag: a ROS 1 .bag or a ROS 2 bag folder (sqlite3); detect in every message "
                 "of --topic");
  app.add_option("--topic",
                 bag.topic,
                 "Bag topic: sensor_msgs/PointCloud2 (camera frame) or sensor_msgs/Image "
                 "(16UC1/mono16 in mm unless --depth-scale, or 32FC1 in m)");
  app.add_option("--camera-info",
                 bag.camera_info_topic,
                 "CameraInfo topic of an Image topic (default: <image namespace>/camera_info)");
  app.add_option("--tf-world",
                 bag.world_frame,
                 "Floor-aligned TF frame (z up, floor at z = 0): where /tf connects it to a "
                 "message's frame that pose is used; '' : find the floor in every scan")
      ->capture_default_str();
  app.add_option("--out-bag",
                 out_bag,
                 "Write a copy of --bag with the detections as visualization_msgs/MarkerArray "
                 "on /furnidet/detections (ROS 2: and vision_msgs/Detection3DArray on "
                 "/furnidet/detections_3d)");
}

// Several posed scans detected at once (--fuse), their poses refined first.
void AddFuseFlags(CLI::App* app, bool* fuse, FrameFusion* fusion, DetectRunOptions* run) {
  app->add_flag("--fuse",
                *fuse,
                "One detection in several scans at once, seen from the last one's camera: each "
                "a world-frame cloud with its own pose (VIEWPOINT, --floor-aligned); with --db "
                "and --frame, the frame with its room's other frames");
  app->add_flag("--fuse-register",
                fusion->register_poses,
                "With --fuse: refine the scans' poses against the last one's points first "
                "(generalized ICP), for poses from odometry");
  AddFusePlanarFlag(app, &fusion->planar);
  app->add_option("--fuse-max-scans",
                  run->fuse_max_scans,
                  "With --fuse: the most scans fused (each is held in memory at once)")
      ->check(CLI::Range(2, 100000))
      ->capture_default_str();
  app->add_option("--fuse-max-points",
                  run->fuse_max_points,
                  "With --fuse: the most points of all the fused scans together")
      ->check(CLI::Range(int64_t{1}, int64_t{1} << 31))
      ->capture_default_str();
}

// The scans: the positional inputs, or the one of --cloud/--depth/--db
// (with --fuse, a --db frame brings its room's frames).
std::vector<ScanSource> ScanSourcesOf(const CLI::App& app,
                                      const std::vector<std::string>& inputs,
                                      ScanSource source,
                                      bool fuse,
                                      const FrameFusion& fusion) {
  if (inputs.empty()) {
    Require(!fuse || !source.db_path.empty(),
            "--fuse needs two or more scans as inputs, or --db with --frame");
    source.fusion = fusion;
    source.fusion.room_frames = fuse;
    return {source};
  }
  Require(!NamesAScan(source), "give scans as inputs or with --cloud/--depth/--db, not both");
  std::vector<ScanSource> sources = ExpandScanInputs(
      inputs, source, app.count("--intrinsics") > 0, app.count("--depth-scale") > 0);
  Require(!fuse || sources.size() >= 2,
          "--fuse needs two or more scans (or --db with --frame: its room's frames)");
  return sources;
}

// Depth images whose camera nobody gave get Kinect v1's: said once on
// stderr (the JSON's "camera" records it too).
void NoteDefaultIntrinsics(const CLI::App& app,
                           const std::vector<ScanSource>& sources,
                           bool quiet) {
  if (quiet || app.count("--intrinsics") > 0) return;
  for (const ScanSource& s : sources) {
    if (s.depth_path.empty() || !s.camera_file.empty() || s.intrinsics != "kinect1") continue;
    const CameraIntrinsics k = CameraIntrinsics::KinectV1();
    std::fprintf(stderr,
                 "note: %s: no --intrinsics or --camera, so Kinect v1's are assumed (fx %g, fy "
                 "%g, cx %g, cy %g for 640x480)\n",
                 PrintableText(s.depth_path).c_str(),
                 k.fx,
                 k.fy,
                 k.cx,
                 k.cy);
    return;
  }
}

}  // namespace

int RunDetect(int argc, char** argv) {
  CLI::App app{"Detect furniture in depth scans: one, or many with the model loaded once",
               "workbench detect"};
  std::string model_path, out, debug_dir;
  std::vector<std::string> inputs;
  ScanSource source;
  bool timings = false, quiet = false, explain = false;
  int repeat = 1;
  app.add_option("--model", model_path, "Model file (.fcm) from workbench train")->required();
  app.add_option("inputs",
                 inputs,
                 "Scans: .pcd/.ply clouds, .png/.tif/.exr depth images, glob patterns, TUM "
                 "lists (.txt) or BOP scene/split folders; several give JSON lines");
  AddScanFlags(&app, &source);
  BagScanOptions bag;
  std::string out_bag;
  AddBagFlags(&app, &bag, &out_bag);
  app.add_option("--db", source.db_path, "Dataset database (with --frame)");
  app.add_option("--frame", source.frame_id, "Frame id in --db");
  app.add_option("--out", out, "Detections as JSON, or JSON lines for several scans");
  app.add_option("--debug-dir",
                 debug_dir,
                 "Write debug PNGs (segments or heat, votes, boxes and fits, top-down) and "
                 "scene.html, the frame in 3-D (opens offline)");
  app.add_flag("--explain", explain, "Print every hypothesis and the test that rejected it");
  app.add_flag("--timings", timings, "Print the time of every stage and of loading the model");
  app.add_option("--repeat", repeat, "Run N times and report median stage times (benchmark)")
      ->capture_default_str();
  DetectorFlags detector_flags(&app);
  bool fuse = false;
  FrameFusion fusion;  // registration only: --fuse decides what is fused
  DetectRunOptions run;
  AddFuseFlags(&app, &fuse, &fusion, &run);
  app.add_flag("--quiet,-q", quiet, "Print nothing but errors");
  app.add_flag("--strict",
               run.strict,
               "Warnings are errors (a --tf-world that the bag's TF cannot resolve)");
  app.add_flag("--resume",
               run.resume,
               "Batches and bags with --out FILE: keep the lines a killed run of the same model, "
               "options and inputs left in FILE.partial and detect only the rest");
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  Progress::SetQuiet(quiet);  // batches and bags show progress unless --quiet
  Require(repeat >= 1 && repeat <= 1000,
          "--repeat " + std::to_string(repeat) + " must be in 1..1000");
  Require(app.count("--frame") == 0 || !source.db_path.empty(),
          "--frame " + std::to_string(source.frame_id) + " applies to --db only");
  run.model_path = model_path;
  run.detector = detector_flags.Resolve();
  run.out = out;
  run.debug_dir = debug_dir;
  run.repeat = repeat;
  run.quiet = quiet;
  run.explain = explain;
  run.timings = timings;
  run.fuse = fuse && !inputs.empty();
  run.fuse_registration = fusion.Registration();
  Require(!fusion.register_poses || fuse, "--fuse-register applies to --fuse");
  Require(!fusion.planar || fusion.register_poses, "--fuse-planar applies to --fuse-register");

  if (!bag.bag_path.empty()) {
    Require(inputs.empty() && !NamesAScan(source),
            "--bag takes no other scans (inputs, --cloud, --depth or --db)");
    Require(debug_dir.empty() && repeat == 1, "--debug-dir and --repeat apply to one scan");
    Require(!fuse, "--fuse applies to scans and --db frames, not to --bag");
    bag.depth_scale = source.depth_scale;
    return DetectInBag(bag, out_bag, run);
  }
  Require(out_bag.empty() && bag.topic.empty() && bag.camera_info_topic.empty(),
          "--topic, --camera-info and --out-bag apply to --bag");

  const std::vector<ScanSource> sources = ScanSourcesOf(app, inputs, source, fuse, fusion);
  NoteDefaultIntrinsics(app, sources, quiet);
  // One plain scan file, or --cloud/--depth/--db: one indented JSON; any
  // other inputs (several, a glob, a list, a folder): JSON lines.
  const bool batch = IsBatch(inputs, sources);
  Require(!run.resume || (batch && !run.fuse),
          "--resume applies to batches of scans and to --bag (one detection has nothing to "
          "resume)");
  return DetectScans(sources, batch, run);
}

}  // namespace furn
