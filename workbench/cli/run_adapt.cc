#include <CLI/CLI.hpp>
#include <iostream>
#include <string>
#include <vector>

#include "core/util/error.h"
#include "core/util/progress.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/commands.h"
#include "workbench/cli/detector_flags.h"
#include "workbench/formats/scan_inputs.h"
#include "workbench/pipelines/adapt.h"

namespace furn {

namespace {

// The flags of --method self-training.
void AddSelfTrainingFlags(CLI::App* app, AdaptOptions* options) {
  app->add_option("--rooms",
                  options->rooms_db,
                  "Self-training: generated rooms of the model's training catalog only (e.g. "
                  "train --keep-rooms' <model>.rooms.db)");
  app->add_option("--rooms-share", options->rooms_share, "Self-training: generated frames per scan")
      ->capture_default_str();
  app->add_option("--epochs", options->epochs, "Self-training: epochs of fine-tuning")
      ->capture_default_str();
  app->add_option("--learning-rate", options->learning_rate, "Self-training: peak learning rate")
      ->capture_default_str();
  app->add_option(
         "--pseudo-share",
         options->pseudo.heat_share,
         "Self-training: a pseudo-target's heat, as a share of its class's operating point")
      ->capture_default_str();
  app->add_option("--mirror-match",
                  options->pseudo.mirror_match_m,
                  "Self-training: the mirror's maximum this near (m) confirms a pseudo-target")
      ->capture_default_str();
  app->add_option("--ignore-heat",
                  options->pseudo.ignore_min_heat,
                  "Self-training: other maxima at least this hot are ignored, not background")
      ->capture_default_str();
  app->add_flag("--scans-background",
                options->scans_background_known,
                "Self-training: a scan's cells away from its pseudo-targets train as background "
                "(default: unknown, only the pseudo-targets' surroundings train)");
}

}  // namespace

int RunAdapt(int argc, char** argv) {
  CLI::App app{
      "Adapt a model's vote network to your sensor and rooms from your own scans, without "
      "labels: its batch normalisation statistics re-estimated on them (AdaBN), or the network "
      "fine-tuned on its own confident detections in them beside generated rooms (self-training)",
      "workbench adapt"};
  AdaptOptions options;
  std::vector<std::string> inputs;
  ScanSource common;
  BagScanOptions bag;
  std::string split = "all";
  std::string method = "normalisation";
  app.add_option("--model", options.model_path, "Model file (.fcm) with a vote network")
      ->required();
  app.add_option("scans",
                 inputs,
                 "Scan files, globs, TUM lists or BOP folders (as detect takes them); labels, if "
                 "any, are never read");
  app.add_option("--intrinsics", common.intrinsics, "kinect1 or fx,fy,cx,cy (depth images)")
      ->capture_default_str();
  app.add_option("--camera", common.camera_file, "Camera file for depth images");
  app.add_option("--depth-scale", common.depth_scale, "Depth units per metre of depth images");
  app.add_option("--db", options.db_path, "Dataset database: its frames as scans (no label read)");
  app.add_option("--split", split, "Of --db: train, val, test or all")->capture_default_str();
  app.add_option("--bag", bag.bag_path, "ROS 1 or ROS 2 bag: every message of --topic");
  app.add_option("--topic", bag.topic, "Bag topic: sensor_msgs/PointCloud2 or sensor_msgs/Image");
  app.add_option("--camera-info", bag.camera_info_topic, "CameraInfo topic of an Image topic");
  app.add_option("--tf-world", bag.world_frame, "Floor-aligned TF frame ('' : find the floor)")
      ->capture_default_str();
  app.add_option("--out", options.out, "Where to write the adapted model")->required();
  app.add_option("--max-frames",
                 options.max_frames,
                 "At most this many scans, drawn by --seed (0: all; each holds ~0.2 MB)")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "Which scans, their order and mirroring")
      ->capture_default_str();
  app.add_option("--blend",
                 options.blend,
                 "The scans' statistics' share against the model's (1: theirs alone)")
      ->capture_default_str();
  app.add_option("--batch", options.batch, "Scans per batch normalisation batch")
      ->capture_default_str();
  app.add_option("--mirror-share", options.mirror_share, "Share of scans used mirrored")
      ->capture_default_str();
  app.add_option("--method", method, "normalisation (AdaBN) or self-training")
      ->capture_default_str();
  AddSelfTrainingFlags(&app, &options);
  DetectorFlags detector_flags(&app, {"--seed"});
  app.add_flag("--quiet,-q", options.quiet, "Print nothing but errors");
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  Progress::SetQuiet(options.quiet);
  options.split = ParseSplit(split, "--split");
  options.method = ParseEnum<AdaptMethod>(method);
  options.detector = detector_flags.Resolve();
  if (!inputs.empty())
    options.sources = ExpandScanInputs(
        inputs, common, app.count("--intrinsics") > 0, app.count("--depth-scale") > 0);
  if (!bag.bag_path.empty()) {
    Require(!bag.topic.empty(), "--bag needs --topic");
    bag.depth_scale = common.depth_scale;
    options.bag = bag;
  } else {
    Require(bag.topic.empty() && bag.camera_info_topic.empty(),
            "--topic and --camera-info apply to --bag");
  }
  Require(options.split == Split::kAll || !options.db_path.empty(), "--split applies to --db");
  const AdaptSummary summary = AdaptModel(options);
  if (!options.quiet) std::cout << AdaptSummaryText(options, summary);
  return 0;
}

}  // namespace furn
