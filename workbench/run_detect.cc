#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <map>

#include "core/error.h"
#include "core/file_util.h"
#include "workbench/cli_common.h"
#include "workbench/commands.h"
#include "workbench/detect_command.h"
#include "workbench/evaluate_command.h"

namespace furn {

int RunDetect(int argc, char** argv) {
  CLI::App app{"Detect furniture in one depth scan", "workbench detect"};
  std::string model_path, out, debug_dir;
  ScanSource source;
  DetectorOptions options;
  bool timings = false, quiet = false;
  int repeat = 1;
  app.add_option("--model", model_path, "Model file (.fcm) from workbench train")->required();
  app.add_option("--cloud", source.cloud_path, "Point cloud (.pcd or .ply), camera frame, metres");
  app.add_option("--depth", source.depth_path, "16-bit depth PNG");
  app.add_option("--intrinsics", source.intrinsics, "kinect1 or fx,fy,cx,cy (with --depth)")
      ->capture_default_str();
  app.add_option("--depth-scale", source.depth_scale, "Depth units per metre (TUM: 5000)")
      ->capture_default_str();
  app.add_option("--db", source.db_path, "Dataset database (with --frame)");
  app.add_option("--frame", source.frame_id, "Frame id in --db");
  app.add_option("--out", out, "Detections as JSON (default: printed)");
  app.add_option("--debug-dir", debug_dir, "Write debug PNGs (segments, votes, fits, top-down)");
  app.add_flag("--timings", timings, "Print the time of every stage");
  app.add_option("--repeat", repeat, "Run N times and report median stage times (benchmark)")
      ->capture_default_str();
  app.add_option("--threshold", options.relative_threshold, "Relative vote threshold t (eq. 8)")
      ->capture_default_str();
  app.add_option("--absolute-threshold", options.absolute_threshold, "Minimum vote weight")
      ->capture_default_str();
  app.add_option("--min-verification", options.min_verification, "Minimum visibility score")
      ->capture_default_str();
  app.add_option("--max-range", options.max_range_m, "Drop points beyond (m)")
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
  if (!options_file.empty()) {
    const DetectorOptions from_file =
        DetectorOptionsFromJson(ReadFileBytes(options_file), options_file);
    DetectorOptions merged = from_file;  // flags given explicitly win over the file
    if (app.count("--threshold")) merged.relative_threshold = options.relative_threshold;
    if (app.count("--absolute-threshold")) merged.absolute_threshold = options.absolute_threshold;
    if (app.count("--min-verification")) merged.min_verification = options.min_verification;
    if (app.count("--max-range")) merged.max_range_m = options.max_range_m;
    if (app.count("--top-models")) merged.top_models = options.top_models;
    if (app.count("--seed")) merged.seed = options.seed;
    options = merged;
  }
  options.Check();
  const LoadedScan scan = LoadScan(source);
  const Detector detector(LoadTrainedModel(model_path), options);

  std::map<std::string, std::vector<double>> stage_times;
  DetectionResult result;
  for (int k = 0; k < repeat; ++k) {
    result = detector.Detect(scan.input, /*keep_debug=*/!debug_dir.empty() && k == repeat - 1);
    // One scan given by the user: nothing in range is most likely a wrong file or unit.
    Require(result.status == DetectionStatus::kDetected, scan.description + ": " + result.message);
    for (const auto& [stage, ms] : result.timings_ms) stage_times[stage].push_back(ms);
  }
  if (!debug_dir.empty()) {  // first: --out may name a file inside it
    WriteDetectionDebug(result, detector.model(), scan.camera, scan.ground_truth, debug_dir);
  }
  const std::string json = DetectionJson(result, scan);
  if (!out.empty()) {
    WriteFileAtomically(out, json);
  } else if (!quiet) {
    std::fputs(json.c_str(), stdout);
  }
  if (!quiet) {
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

}  // namespace furn
