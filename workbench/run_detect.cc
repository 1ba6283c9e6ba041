#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <optional>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/file_util.h"
#include "core/progress.h"
#include "workbench/cli_common.h"
#include "workbench/commands.h"
#include "workbench/detect_command.h"
#include "workbench/evaluate_command.h"
#include "workbench/rosbag_io.h"

namespace furn {
namespace {

void PrintDetections(const LoadedScan& scan, const DetectionResult& result) {
  std::fprintf(stderr, "%s: %zu detections", scan.description.c_str(), result.detections.size());
  for (const Detection& d : result.detections) {
    std::fprintf(stderr,
                 "\n  %-9s x %6.2f  y %6.2f  yaw %5.1f deg  score %.2f  %s",
                 ClassName(d.furniture_class),
                 d.x,
                 d.y,
                 d.yaw * 180 / M_PI,
                 d.score,
                 d.model_name.c_str());
  }
  std::fprintf(stderr, "\n");
}

// `detect --bag`: one JSON line per message (with its topic, stamp and
// seq), the model loaded once; --out-bag adds the detections as markers.
int DetectInBag(const BagScanOptions& bag,
                const std::string& out_bag,
                const std::string& model_path,
                const DetectorOptions& options,
                const std::string& out,
                bool quiet,
                bool explain) {
  RequireRegularFile(bag.bag_path);  // before the model loads: a wrong path fails at once
  const Detector detector(LoadTrainedModel(model_path), options);
  std::optional<BagMarkerWriter> markers;
  if (!out_bag.empty()) markers.emplace(bag.bag_path, out_bag, bag.world_frame);
  std::string lines;
  std::vector<double> totals;
  int without = 0;
  std::optional<Progress> progress;
  ForEachBagScan(bag, [&](const BagScan& scan) {
    if (!progress) progress.emplace("detect", scan.total, "messages");  // its clock starts here
    const DetectionResult result = detector.Detect(scan.loaded.input, /*keep_debug=*/false);
    // The message's place in the bag first, then what DetectionJson says.
    const nlohmann::ordered_json place{{"topic", scan.topic},
                                       {"stamp", scan.stamp},
                                       {"seq", scan.seq},
                                       {"frame_id", scan.frame_id}};
    const std::string place_text = place.dump();  // {"topic":...}
    std::string line;
    if (result.status != DetectionStatus::kDetected) {
      line = ScanErrorJson(scan.loaded.description, result.message);
      ++without;
    } else {
      line = DetectionJson(result, scan.loaded, /*one_line=*/true);
      totals.push_back(result.timings_ms.empty() ? 0 : result.timings_ms.back().second);
    }
    // Both are one-line JSON objects: splice the place in after the brace.
    line = place_text.substr(0, place_text.size() - 1) + "," + line.substr(1);
    lines += line;
    if (markers) markers->Add(scan, result, detector.model());
    if (explain) {
      std::fprintf(stderr, "%s: ", scan.loaded.description.c_str());
      std::fputs(ExplainDetection(result, detector.model()).c_str(), stderr);
    }
    progress->Advance();
  });
  if (progress) progress->Finish();
  if (markers) markers->Finish();
  if (!out.empty()) {
    WriteFileAtomically(out, lines);
  } else if (!quiet) {
    std::fputs(lines.c_str(), stdout);
  }
  if (!quiet) {
    std::sort(totals.begin(), totals.end());
    std::fprintf(stderr,
                 "%s %s: %zu messages, %d without points or floor; detection median %.0f ms%s%s\n",
                 bag.bag_path.c_str(),
                 bag.topic.c_str(),
                 totals.size() + without,
                 without,
                 totals.empty() ? 0.0 : totals[totals.size() / 2],
                 out_bag.empty() ? "" : "; markers in ",
                 out_bag.c_str());
  }
  return 0;
}

}  // namespace

int RunDetect(int argc, char** argv) {
  CLI::App app{"Detect furniture in depth scans: one, or many with the model loaded once",
               "workbench detect"};
  std::string model_path, out, debug_dir;
  std::vector<std::string> inputs;
  ScanSource source;
  DetectorOptions options;
  bool timings = false, quiet = false, explain = false, no_scorer = false;
  int repeat = 1;
  app.add_option("--model", model_path, "Model file (.fcm) from workbench train")->required();
  app.add_option("inputs",
                 inputs,
                 "Scans: .pcd/.ply clouds, .png/.tif/.exr depth images, glob patterns, TUM "
                 "lists (.txt) or BOP scene/split folders; several give JSON lines");
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
  app.add_option("--world-from-camera",
                 source.world_from_camera,
                 "Cloud in a world frame: the camera's pose in it, 16 numbers (4x4, row by row) "
                 "or x,y,z,qw,qx,qy,qz (default: the PCD VIEWPOINT)");
  app.add_flag("--floor-aligned",
               source.floor_aligned,
               "The world frame is floor-aligned (z up, floor at z = 0): its pose is used, the "
               "floor not searched");
  app.add_option("--sensor",
                 source.sensor,
                 "Sensor position x,y,z of a floor-aligned unorganised cloud without a pose");
  BagScanOptions bag;
  std::string out_bag;
  app.add_option("--bag", bag.bag_path, "ROS 1 bag: detect in every message of --topic");
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
                 "on /furnidet/detections");
  app.add_option("--db", source.db_path, "Dataset database (with --frame)");
  app.add_option("--frame", source.frame_id, "Frame id in --db");
  app.add_option("--out", out, "Detections as JSON, or JSON lines for several scans");
  app.add_option("--debug-dir", debug_dir, "Write debug PNGs (segments, votes, fits, top-down)");
  app.add_flag("--explain", explain, "Print every hypothesis and the test that rejected it");
  app.add_flag("--timings", timings, "Print the time of every stage and of loading the model");
  app.add_option("--repeat", repeat, "Run N times and report median stage times (benchmark)")
      ->capture_default_str();
  app.add_option("--threshold", options.relative_threshold, "Relative vote threshold t (eq. 8)")
      ->capture_default_str();
  app.add_option("--absolute-threshold", options.absolute_threshold, "Minimum vote weight")
      ->capture_default_str();
  app.add_option("--min-covered",
                 options.min_covered_fraction,
                 "Fixed gates: share of the box's points a fit must explain")
      ->capture_default_str();
  app.add_option("--own-segments",
                 options.own_segment_share,
                 "Count in the covered share only segments at least this much inside the fit's "
                 "box (0: off; e.g. 0.5 finds chairs pushed under desks)")
      ->capture_default_str();
  app.add_option("--min-verification", options.min_verification, "Fixed gates: visibility score")
      ->capture_default_str();
  app.add_option("--min-seen",
                 options.min_seen_occupied,
                 "Fixed gates: share of the fit's observable surface seen")
      ->capture_default_str();
  app.add_option("--min-score", options.min_score, "Fixed gates: ranking score")
      ->capture_default_str();
  app.add_option("--min-probability",
                 options.min_probability,
                 "With the model's scorer: least detection probability")
      ->capture_default_str();
  app.add_flag(
      "--no-scorer", no_scorer, "Decide by the fixed gates even if the model has a scorer");
  app.add_option("--max-range", options.max_range_m, "Drop points beyond (m)")
      ->capture_default_str();
  app.add_option("--floor-band", options.floor_band_m, "Points below this height are floor (m)")
      ->capture_default_str();
  app.add_option("--floor-max-tilt",
                 options.floor.max_tilt_deg,
                 "Floor search: largest angle of the floor to the camera's up (deg)")
      ->capture_default_str();
  app.add_option(
         "--floor-distance", options.floor.distance_m, "Floor search: RANSAC inlier distance (m)")
      ->capture_default_str();
  app.add_option("--top-models", options.top_models, "CAD models fitted per hypothesis")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "Seed of the RANSAC draws")->capture_default_str();
  std::string options_file;
  app.add_option("--options",
                 options_file,
                 "Detector options as JSON (a run's options or a tuned file); flags given "
                 "on the command line are applied on top");
  app.add_flag("--quiet", quiet, "Print nothing but errors");
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  Require(repeat >= 1 && repeat <= 1000,
          "--repeat " + std::to_string(repeat) + " must be in 1..1000");
  Require(app.count("--frame") == 0 || !source.db_path.empty(),
          "--frame " + std::to_string(source.frame_id) + " applies to --db only");
  if (!options_file.empty()) {
    DetectorOptions merged = DetectorOptionsFromJson(ReadFileBytes(options_file), options_file);
    // Flags given explicitly win over the file.
    const auto apply = [&](const char* flag, auto member) {
      if (app.count(flag)) merged.*member = options.*member;
    };
    apply("--threshold", &DetectorOptions::relative_threshold);
    apply("--absolute-threshold", &DetectorOptions::absolute_threshold);
    apply("--min-covered", &DetectorOptions::min_covered_fraction);
    apply("--own-segments", &DetectorOptions::own_segment_share);
    apply("--min-verification", &DetectorOptions::min_verification);
    apply("--min-seen", &DetectorOptions::min_seen_occupied);
    apply("--min-score", &DetectorOptions::min_score);
    apply("--min-probability", &DetectorOptions::min_probability);
    apply("--max-range", &DetectorOptions::max_range_m);
    apply("--floor-band", &DetectorOptions::floor_band_m);
    apply("--top-models", &DetectorOptions::top_models);
    apply("--seed", &DetectorOptions::seed);
    if (app.count("--floor-max-tilt")) merged.floor.max_tilt_deg = options.floor.max_tilt_deg;
    if (app.count("--floor-distance")) merged.floor.distance_m = options.floor.distance_m;
    options = merged;
  }
  if (no_scorer) options.use_scorer = false;
  options.Check();

  if (!bag.bag_path.empty()) {
    Require(inputs.empty() && source.cloud_path.empty() && source.depth_path.empty() &&
                source.db_path.empty(),
            "--bag takes no other scans (inputs, --cloud, --depth or --db)");
    Require(debug_dir.empty() && repeat == 1, "--debug-dir and --repeat apply to one scan");
    bag.depth_scale = source.depth_scale;
    return DetectInBag(bag, out_bag, model_path, options, out, quiet, explain);
  }
  Require(out_bag.empty() && bag.topic.empty() && bag.camera_info_topic.empty(),
          "--topic, --camera-info and --out-bag apply to --bag");

  // The scans: the positional inputs, or the one of --cloud/--depth/--db.
  std::vector<ScanSource> sources;
  if (!inputs.empty()) {
    Require(source.cloud_path.empty() && source.depth_path.empty() && source.db_path.empty(),
            "give scans as inputs or with --cloud/--depth/--db, not both");
    sources = ExpandScanInputs(
        inputs, source, app.count("--intrinsics") > 0, app.count("--depth-scale") > 0);
  } else {
    sources.push_back(source);
  }
  // One plain scan file, or --cloud/--depth/--db: one indented JSON; any
  // other inputs (several, a glob, a list, a folder): JSON lines.
  const bool batch = sources.size() > 1 ||
                     (!inputs.empty() && inputs[0].find_first_of("*?[") != std::string::npos) ||
                     (!inputs.empty() && !sources.empty() &&
                      (sources[0].cloud_path.empty() ? sources[0].depth_path
                                                     : sources[0].cloud_path) != inputs[0]);
  Require(!batch || debug_dir.empty(), "--debug-dir applies to one scan");
  Require(!batch || repeat == 1, "--repeat applies to one scan");
  // One scan is checked before the model loads: a bad file fails fast.
  std::optional<LoadedScan> first;
  if (!batch) first = LoadScan(sources[0]);

  const auto load_start = std::chrono::steady_clock::now();
  const Detector detector(LoadTrainedModel(model_path), options);
  const double load_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - load_start)
          .count();
  if (timings) std::fprintf(stderr, "model loaded in %.0f ms\n", load_ms);

  if (!batch) {
    const LoadedScan& scan = *first;
    std::map<std::string, std::vector<double>> stage_times;
    DetectionResult result;
    for (int k = 0; k < repeat; ++k) {
      result = detector.Detect(scan.input, /*keep_debug=*/!debug_dir.empty() && k == repeat - 1);
      // One scan given by the user: nothing in range is most likely a wrong file or unit.
      Require(result.status == DetectionStatus::kDetected,
              scan.description + ": " + result.message);
      for (const auto& [stage, ms] : result.timings_ms) stage_times[stage].push_back(ms);
    }
    if (!debug_dir.empty()) {  // first: --out may name a file inside it
      WriteDetectionDebug(result,
                          detector.model(),
                          scan.camera,
                          GroundTruthInDetectorFrame(scan, result),
                          debug_dir);
    }
    const std::string json = DetectionJson(result, scan);
    if (!out.empty()) {
      WriteFileAtomically(out, json);
    } else if (!quiet) {
      std::fputs(json.c_str(), stdout);
    }
    if (!quiet) PrintDetections(scan, result);
    if (explain) std::fputs(ExplainDetection(result, detector.model()).c_str(), stderr);
    if (timings || repeat > 1) {
      std::fprintf(stderr,
                   "stage times (ms, %s of %d run%s):\n",
                   repeat > 1 ? "median" : "one",
                   repeat,
                   repeat > 1 ? "s" : "");
      for (const auto& [stage, ms] : result.timings_ms) {
        std::vector<double> runs = stage_times[stage];
        std::nth_element(runs.begin(), runs.begin() + runs.size() / 2, runs.end());
        std::fprintf(stderr, "  %-16s %8.1f\n", stage.c_str(), runs[runs.size() / 2]);
      }
    }
    return 0;
  }

  // A batch: one JSON line per scan, in input order; a scan that cannot be
  // read gets a line with its error and the others go on.
  std::string lines;
  int failed = 0;
  std::vector<double> totals;
  Progress progress("detect", sources.size(), "scans");
  for (const ScanSource& s : sources) {
    try {
      const LoadedScan scan = LoadScan(s);
      const DetectionResult result = detector.Detect(scan.input, /*keep_debug=*/false);
      if (result.status != DetectionStatus::kDetected) {
        lines += ScanErrorJson(scan.description, result.message);
        ++failed;
      } else {
        lines += DetectionJson(result, scan, /*one_line=*/true);
        totals.push_back(result.timings_ms.empty() ? 0 : result.timings_ms.back().second);
        if (explain) {
          std::fprintf(stderr, "%s: ", scan.description.c_str());
          std::fputs(ExplainDetection(result, detector.model()).c_str(), stderr);
        }
      }
    } catch (const InputError& e) {
      lines += ScanErrorJson(ScanSourceName(s), e.what());
      ++failed;
    }
    progress.Advance();
  }
  progress.Finish();
  if (!out.empty()) {
    WriteFileAtomically(out, lines);
  } else if (!quiet) {
    std::fputs(lines.c_str(), stdout);
  }
  if (!quiet || failed > 0) {
    std::sort(totals.begin(), totals.end());
    std::fprintf(stderr,
                 "%zu scans: %zu detected, %d failed (their lines say why); model loaded in "
                 "%.0f ms, detection median %.0f ms\n",
                 sources.size(),
                 totals.size(),
                 failed,
                 load_ms,
                 totals.empty() ? 0.0 : totals[totals.size() / 2]);
  }
  return failed > 0 ? 1 : 0;
}

}  // namespace furn
