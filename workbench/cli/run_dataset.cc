#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "scenes/room_composer.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/cluster_flags.h"
#include "workbench/cli/commands.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/rosbag_io.h"
#include "workbench/formats/scan_file.h"
#include "workbench/formats/sensor_file.h"
#include "workbench/pipelines/convert_nyu.h"
#include "workbench/pipelines/dataset_tools.h"
#include "workbench/pipelines/export_rosbag.h"
#include "workbench/pipelines/floor_check.h"
#include "workbench/pipelines/generate.h"
#include "workbench/pipelines/import_real.h"
#include "workbench/pipelines/sensor_noise.h"

namespace furn {

namespace {

void PrintGenerateSummary(const std::string& out,
                          const GenerateOptions& options,
                          const GenerateSummary& summary) {
  std::printf(
      "%s: %d rooms in shard %d/%d: %d written, %d already present; %d frames in %.1f s (%.1f "
      "frames/s)\n",
      out.c_str(),
      summary.rooms_in_shard,
      options.shard_index,
      options.shard_count,
      summary.rooms_written,
      summary.rooms_already_present,
      summary.frames_written,
      summary.seconds,
      summary.seconds > 0 ? summary.frames_written / summary.seconds : 0.0);
  std::printf(
      "time per stage (s; render to png summed over %d workers): compose %.2f, load models %.2f, "
      "render+noise %.2f, ground truth %.2f, png %.2f, database %.2f\n",
      summary.workers,
      summary.compose_s,
      summary.load_s,
      summary.render_s,
      summary.ground_truth_s,
      summary.encode_s,
      summary.insert_s);
  if (summary.rooms_short > 0) {
    std::printf(
        "note: in %d of %d rooms not every requested piece fitted (rooms too small for the "
        "request; "
        "placed what fits)\n",
        summary.rooms_short,
        summary.rooms_written);
  }
}

}  // namespace

namespace {

// `generate` as an array job: task i makes shard i/N into the job folder, the
// final job merges the N shards into --out.
ArrayJob GenerateArrayJob(const ClusterFlags& cluster,
                          const std::string& out,
                          int argc,
                          char** argv) {
  Require(std::filesystem::path(out).extension() == ".db",
          out + ": the dataset file must end in .db");
  ArrayJob job = NewArrayJob(cluster, "generate");
  SetTaskOutput(&job, "shard-", ".db");
  job.task_command = TaskCommandLine(
      argc,
      argv,
      {"--out", "--shard"},
      "--quiet --shard " + TaskShardArgument(job) + " --out " + TaskOutputArgument(job));
  job.final_output = std::filesystem::absolute(out).string();
  job.final_command = WorkbenchCommand("dataset merge --quiet") + AllTaskOutputs(job) + " --out " +
                      ShellQuote(job.final_output);
  return job;
}

}  // namespace

int RunGenerate(int argc, char** argv) {
  CLI::App app{
      "Generate labelled synthetic Kinect frames of furnished rooms into a dataset database",
      "workbench generate"};
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  GenerateOptions options;
  std::string out, shard = "0/1", renderer = "embree";
  app.add_option("--rooms", options.rooms, "Rooms in the whole run (all shards)")
      ->capture_default_str();
  app.add_option("--frames", options.room.frames_per_room, "Frames per room")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "Master seed")->capture_default_str();
  app.add_option(
         "--out", out, "Dataset database (.db); an existing one with the same options is resumed")
      ->required();
  app.add_option("--shard", shard, "i/N: make only rooms k with k % N == i")->capture_default_str();
  app.add_option("--renderer", renderer, "embree or osmesa")->capture_default_str();
  app.add_option("--min-side", options.room.min_side_m, "Smallest room side (m)")
      ->capture_default_str();
  app.add_option("--max-side", options.room.max_side_m, "Largest room side (m)")
      ->capture_default_str();
  app.add_option(
         "--min-furniture", options.room.min_furniture, "Fewest class-mapped pieces per room")
      ->capture_default_str();
  app.add_option("--max-furniture", options.room.max_furniture, "Most class-mapped pieces per room")
      ->capture_default_str();
  app.add_option("--min-clutter", options.room.min_clutter, "Fewest clutter pieces per room")
      ->capture_default_str();
  app.add_option("--max-clutter", options.room.max_clutter, "Most clutter pieces per room")
      ->capture_default_str();
  app.add_option("--max-clutter-side",
                 options.room.max_clutter_side_m,
                 "Longest footprint side of a clutter entry (m; larger lets beds, long shelves "
                 "and kitchen runs in)")
      ->capture_default_str();
  app.add_option("--surface-clutter",
                 options.room.surface_clutter,
                 "Share of the tables and sideboards with one to three small clutter pieces on "
                 "top (0..1)")
      ->capture_default_str();
  app.add_option("--model-folds",
                 options.model_folds,
                 "Leave-models-out rooms: K folds of the class-mapped models, room k's targets "
                 "from fold k % K only (for 'workbench crossval'); 0 = off")
      ->capture_default_str();
  app.add_option("--fold-seed", options.fold_seed, "Seed of the split into model folds")
      ->capture_default_str();
  app.add_option("--clutter-catalog",
                 options.clutter_catalog_specs,
                 "Add this catalog's unclassified entries as clutter (repeatable; a class map, "
                 "'default' or a .sh3f, whose every entry counts as unclassified)");
  std::string sensor_file;
  app.add_option("--sensor",
                 sensor_file,
                 "Sensor file (dataset noise --fit --out): the Kinect noise the frames get "
                 "(default: the published model)");
  ClusterFlags cluster;
  AddClusterFlags(&app, &cluster);
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);
  if (!sensor_file.empty()) options.noise = ReadSensorFile(sensor_file);
  cluster.Check();
  if (cluster.Active()) {
    Require(app.count("--shard") == 0, "--shard i/N and --shards N do not go together");
    return RunArrayJob(cluster, GenerateArrayJob(cluster, out, argc, argv));
  }
  std::tie(options.shard_index, options.shard_count) = ParseShard(shard);
  options.renderer = ParseRendererKind(renderer);
  options.catalog_spec = catalog_flags.spec;
  options.Check();
  Require(std::filesystem::path(out).extension() == ".db",
          out + ": the dataset file must end in .db");
  const Catalog catalog = OpenGenerationCatalog(catalog_flags.spec,
                                                options.clutter_catalog_specs,
                                                MakeOpenOptions(catalog_flags),
                                                options.room,
                                                catalog_flags.quiet);
  const GenerateSummary summary = GenerateDataset(catalog, options, out);
  PrintGenerateSummary(out, options, summary);
  return 0;
}

namespace {

// BOP export's catalog folders, from the flags or the environment.
void AddExportCatalogFlags(CLI::App* export_command, CatalogFlags* export_catalog) {
  if (const char* env = std::getenv("FURN_CATALOG_DIR")) export_catalog->catalog_dir = env;
  if (const char* env = std::getenv("FURN_DATA_DIR")) export_catalog->data_dir = env;
  export_command
      ->add_option("--catalog-dir",
                   export_catalog->catalog_dir,
                   "bop: directory of the .sh3f files of the dataset's catalog (env "
                   "FURN_CATALOG_DIR)")
      ->capture_default_str();
  export_command
      ->add_option("--data-dir",
                   export_catalog->data_dir,
                   "bop: directory of class_map.json (env FURN_DATA_DIR)")
      ->capture_default_str();
}

}  // namespace

namespace {

// `workbench dataset`'s subcommands and their flags (bound in place: not
// copied or moved once made).
struct DatasetCommands {
  CLI::App *info, *preview, *merge, *export_command, *import_real, *noise, *convert_nyu, *floors;
  std::string db, out, format = "bop", export_split = "all", labels, sheets, sensor_file;
  std::string storage = "sqlite3";
  std::vector<std::string> inputs;
  bool json = false, allow_partial = false, quiet = false, fit = false;
  int max_frames = 12, noise_frames = 0;
  CatalogFlags export_catalog;  // where BOP export finds the dataset's catalog
  NyuConvertOptions nyu;
  FloorCheckOptions floor_check;
  FloorOptions floor_options;  // the detector's defaults

  explicit DatasetCommands(CLI::App* app) {
    info = app->add_subcommand("info", "Counts per split and class, visibility histogram, size");
    info->add_option("db", db, "Dataset database")->required();
    info->add_flag("--json", json, "JSON instead of text");
    preview = app->add_subcommand("preview", "Contact sheet: noisy depth with ground-truth boxes");
    preview->add_option("db", db, "Dataset database")->required();
    preview->add_option("--out", out, "Output .png")->required();
    preview->add_option("--frames", max_frames, "How many frames (spread over the dataset)")
        ->capture_default_str();
    merge =
        app->add_subcommand("merge", "Join datasets of one run (e.g. its shards) into a new file");
    merge->add_option("inputs", inputs, "Input datasets")->required();
    merge->add_option("--out", out, "New dataset file")->required();
    merge->add_flag(
        "--allow-partial",
        allow_partial,
        "Merge even when the inputs lack rooms their generation made (a shard left out)");
    export_command = app->add_subcommand("export", "Write frames as BOP, PNG or PCD files");
    export_command->add_option("db", db, "Dataset database")->required();
    export_command->add_option("--format", format, "bop, png, pcd or rosbag")
        ->capture_default_str();
    export_command
        ->add_option("--out",
                     out,
                     "Output directory (rosbag: a .bag file for ROS 1, else a ROS 2 bag folder)")
        ->required();
    export_command
        ->add_option("--storage",
                     storage,
                     "rosbag to a ROS 2 folder: sqlite3 (Humble's default) or mcap (Iron, Jazzy)")
        ->capture_default_str();
    export_command->add_option("--split", export_split, "rosbag: frames of train, val, test or all")
        ->capture_default_str();
    AddExportCatalogFlags(export_command, &export_catalog);
    import_real = app->add_subcommand(
        "import-real", "Labelled real scans (a furnidet-real-set JSON) into a new dataset");
    import_real->add_option("labels", labels, "Real-set JSON (data/real/labels.json)")->required();
    import_real->add_option("--out", out, "New dataset file")->required();
    import_real->add_option("--sheets", sheets, "Write a top-down label sheet per scan here");
    noise = app->add_subcommand(
        "noise",
        "Sim-to-real: depth noise on a dataset's floors and walls against the sensor model");
    noise->add_option("db", db, "Dataset database (an imported real set, or generated frames)")
        ->required();
    noise->add_flag("--json", json, "JSON instead of text");
    noise->add_option("--frames", noise_frames, "At most N frames (0: all)")->capture_default_str();
    noise->add_option("--sensor",
                      sensor_file,
                      "Compare this sensor file's model (default: the "
                      "published one)");
    noise->add_flag("--fit",
                    fit,
                    "Fit the model's noise scale and correlated share to the frames (from "
                    "--sensor's model or the published one)");
    noise->add_option("--out", out, "With --fit: write the fitted model as a sensor file");
    AddConvertNyu(app);
    AddFloors(app);
    for (CLI::App* command :
         {info, preview, merge, export_command, import_real, noise, convert_nyu, floors})
      command->add_flag("--quiet,-q", quiet, "No progress output");
  }
  void AddConvertNyu(CLI::App* app) {
    convert_nyu = app->add_subcommand(
        "convert-nyu",
        "NYU Depth V2 labelled frames (official train split only) into a real set for "
        "import-real: depth PNGs, floors and instances derived from the class masks");
    convert_nyu
        ->add_option("--source",
                     nyu.source_dir,
                     "Checkout holding data/nyu_depths, data/nyu_labels40, data/nyu_images "
                     "(markshih91/refinenet_pytorch; tools/fetch_nyu.sh)")
        ->required();
    convert_nyu->add_option("--splits", nyu.splits_path, "NYU's splits.mat (trainNdxs, testNdxs)")
        ->required();
    convert_nyu->add_option("--out", nyu.out_dir, "New folder: labels.json, depth/, README.md")
        ->required();
    convert_nyu
        ->add_option(
            "--max-frames", nyu.max_frames, "At most N frames, spread over the split (0: all)")
        ->capture_default_str();
    convert_nyu->add_flag("--overlays",
                          nyu.overlays,
                          "Also an RGB overlay per frame with its floor and derived instances");
    convert_nyu
        ->add_option("--dequantise-radius",
                     nyu.dequantise_radius,
                     "Average each 8-bit depth step with its neighbours within one step "
                     "in this radius (px; 0: off)")
        ->capture_default_str();
    convert_nyu
        ->add_option("--max-range",
                     nyu.derive.max_range_m,
                     "Instances farther than this (m, on the floor) are ignored")
        ->capture_default_str();
  }
  void AddFloors(CLI::App* app) {
    floors = app->add_subcommand(
        "floors", "The detector's floor search against a dataset's true floors (real sets)");
    floors->add_option("db", db, "Dataset database (an imported real set)")->required();
    floors->add_flag("--json", json, "JSON instead of text");
    floors->add_flag("--all-frames",
                     floor_check.all_frames,
                     "Also frames whose pose is known (generated datasets)");
    floors->add_option("--frames", floor_check.max_frames, "At most N frames (0: all)")
        ->capture_default_str();
    floors
        ->add_option("--max-angle",
                     floor_check.max_angle_deg,
                     "A floor is right within this tilt (degrees) ...")
        ->capture_default_str();
    floors
        ->add_option(
            "--max-height-error", floor_check.max_height_m, "... and this camera-height error (m)")
        ->capture_default_str();
    floors
        ->add_option("--search-range",
                     floor_check.search_range_m,
                     "Floor search among the points this near the camera (m; the detector "
                     "uses this or its --max-range, whichever is larger)")
        ->capture_default_str();
    // The detector's floor options, to tune them (the same as detect's).
    floors
        ->add_option("--floor-distance",
                     floor_options.distance_m,
                     "Floor search: RANSAC inlier distance (m)")
        ->capture_default_str();
    floors
        ->add_option("--floor-max-tilt",
                     floor_options.max_tilt_deg,
                     "Floor search: largest angle of the floor to the camera's up (deg)")
        ->capture_default_str();
    floors
        ->add_option("--floor-sample",
                     floor_options.sample_points,
                     "Floor search: RANSAC draws from about this many of the points")
        ->capture_default_str();
    floors
        ->add_option("--floor-min-fraction",
                     floor_options.min_fraction,
                     "Floor search: the floor's share of the points lower than the camera")
        ->capture_default_str();
  }
  DatasetCommands(const DatasetCommands&) = delete;
  DatasetCommands& operator=(const DatasetCommands&) = delete;
};

void RunExport(const DatasetCommands& c) {
  if (c.format == "rosbag") {
    const Ros2Storage storage = Ros2StorageFromName(c.storage, "--storage");
    Require(c.storage == "sqlite3" || FileExtension(c.out) != "bag",
            "--storage applies to ROS 2 bag folders, not to the ROS 1 bag " + c.out);
    const int frames = ExportRosbag(c.db, c.out, c.export_split, storage);
    std::cout << "wrote " << frames << " frames to " << c.out << " (rosbag)\n";
    return;
  }
  Require(c.export_split == "all", "--split applies to --format rosbag");
  Require(c.storage == "sqlite3", "--storage applies to --format rosbag");
  int frames = 0;  // a failed export leaves no partial folder
  WriteDirectoryAtomically(c.out, [&](const std::string& dir) {
    frames = ExportDataset(c.db, c.format, dir, MakeOpenOptions(c.export_catalog));
  });
  std::cout << "wrote " << frames << " frames to " << c.out << " (" << c.format << ")\n";
}

// `dataset noise`: the comparison, or with --fit the fitted model (and its
// sensor file).
void RunNoise(const DatasetCommands& c) {
  Require(c.noise_frames >= 0, "--frames must be >= 0");
  Require(c.out.empty() || c.fit, "--out applies to --fit");
  const KinectNoiseOptions sensor =
      c.sensor_file.empty() ? KinectNoiseOptions{} : ReadSensorFile(c.sensor_file);
  const std::vector<NoiseFrame> frames = NoiseFramesOf(c.db, c.noise_frames);
  if (!c.fit) {
    const SensorNoiseComparison comparison = CompareSensorNoise(frames, sensor, 1);
    std::cout << (c.json ? SensorNoiseJson(comparison) : SensorNoiseText(comparison));
    return;
  }
  const SensorFit fit = FitSensorNoise(frames, sensor, 1);
  const std::string fitted_on = c.db + ", " + std::to_string(fit.after.frames) + " frames";
  if (!c.out.empty()) WriteFileAtomically(c.out, SensorFileJson(fit.options, fitted_on, fit.error));
  if (c.json) {
    std::cout << SensorFitJson(fit);
    return;
  }
  std::printf("before (%s):\n%s",
              c.sensor_file.empty() ? "the published model" : c.sensor_file.c_str(),
              SensorNoiseText(fit.before).c_str());
  std::printf("fitted over %d models: noise_scale %.2f, correlated_share %.2f (radius %d px):\n%s",
              fit.candidates,
              fit.options.noise_scale,
              fit.options.correlated_share,
              fit.options.correlation_radius_px,
              SensorNoiseText(fit.after).c_str());
  if (!c.out.empty()) std::printf("wrote %s\n", c.out.c_str());
}

}  // namespace

int RunDataset(int argc, char** argv) {
  CLI::App app{"Inspect, preview, merge and export dataset databases", "workbench dataset"};
  app.require_subcommand(1);
  const DatasetCommands c(&app);
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  Progress::SetQuiet(c.quiet);
  if (c.convert_nyu->parsed()) {
    const NyuConvertSummary summary = ConvertNyu(c.nyu);
    std::cout << "wrote " << c.nyu.out_dir << ": " << summary.frames << " of "
              << summary.train_frames << " train-split frames (" << summary.frames_left_out
              << " left out without a trusted floor), " << summary.targets << " target and "
              << summary.ignored << " ignored instances\n";
  } else if (c.floors->parsed()) {
    const FloorCheck check = CheckFloors(c.db, c.floor_options, c.floor_check);
    std::cout << (c.json ? FloorCheckJson(check) : FloorCheckText(check));
  } else if (c.noise->parsed()) {
    RunNoise(c);
  } else if (c.import_real->parsed()) {
    const RealImportSummary summary = ImportRealSet(ReadRealSet(c.labels), c.out, c.sheets);
    std::cout << "wrote " << c.out << ": " << summary.frames << " real scans, " << summary.objects
              << " labelled objects\n";
  } else if (c.merge->parsed()) {
    const MergeSummary summary = MergeDatasets(c.inputs, c.out, c.allow_partial);
    std::cout << "wrote " << c.out << ": " << summary.rooms << " rooms from " << c.inputs.size()
              << " datasets (" << summary.duplicate_rooms << " duplicate rooms were identical)\n";
  } else if (c.export_command->parsed()) {
    RunExport(c);
  } else if (c.info->parsed()) {
    const DatasetInfo summary = ReadDatasetInfo(c.db);
    std::cout << (c.json ? DatasetInfoJson(summary) : DatasetInfoText(summary));
  } else {
    WriteDatasetPreview(c.db, c.max_frames, c.out);
    std::cout << "wrote " << c.out << "\n";
  }
  return 0;
}

}  // namespace furn
