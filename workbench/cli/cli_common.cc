#include "workbench/cli/cli_common.h"

#include <algorithm>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <sstream>

#include "core/util/progress.h"
#include "core/util/text.h"
#include "workbench/cli/enum_option.h"
#include "workbench/formats/scan_file.h"
#include "workbench/formats/sensor_file.h"

namespace furn {

void AddCatalogFlags(CLI::App* app, CatalogFlags* flags) {
  if (const char* env = std::getenv("FURN_CATALOG_DIR")) flags->catalog_dir = env;
  if (const char* env = std::getenv("FURN_DATA_DIR")) flags->data_dir = env;
  app->add_option(
         "--catalog", flags->spec, "default, procedural[:SEED], a class map .json, or a .sh3f file")
      ->capture_default_str();
  app->add_option(
         "--catalog-dir", flags->catalog_dir, "Directory of the .sh3f files (env FURN_CATALOG_DIR)")
      ->capture_default_str();
  // The default is found beside the program (DefaultDataDir): a path of
  // this machine, not shown as if it were a choice.
  app->add_option("--data-dir",
                  flags->data_dir,
                  "Directory of class_map.json (default: share/furnidet/data beside the "
                  "installed or built program; env FURN_DATA_DIR)");
  app->add_flag("--quiet,-q", flags->quiet, "No progress output");
}

void ApplyGlobalFlags(const CatalogFlags& flags) { Progress::SetQuiet(flags.quiet); }

CatalogOpenOptions MakeOpenOptions(const CatalogFlags& flags) {
  CatalogOpenOptions options;
  options.catalog_dir = flags.catalog_dir;
  options.data_dir = flags.data_dir;
  return options;
}

namespace {

// Seeds are unsigned 64-bit numbers; CLI11 would wrap "-1" to 2^64 - 1.
void CheckSeedsAreUnsigned(CLI::App* app) {
  for (CLI::Option* option : app->get_options()) {
    if (option->get_name().find("seed") == std::string::npos) continue;
    option->check(
        [name = option->get_name()](const std::string& value) -> std::string {
          const bool digits =
              !value.empty() && value.size() <= 20 &&
              std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; });
          if (digits && (value.size() < 20 || value <= "18446744073709551615")) return "";
          return name + " " + value + " must be a whole number in 0..2^64-1";
        },
        "unsigned seed");
  }
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; }))
    CheckSeedsAreUnsigned(sub);
}

// "ENUM:value in {auto->0,codebook->1} OR {0,1}" -> "{auto,codebook}";
// "UINT:unsigned seed" -> "UINT": the type a user types, not the library's.
std::string PlainTypeName(const std::string& type) {
  const std::string kEnum = "ENUM:value in {";
  if (type.rfind(kEnum, 0) == 0) {
    const size_t end = type.find('}', kEnum.size());
    std::string names, entry;
    std::istringstream entries(type.substr(kEnum.size(), end - kEnum.size()));
    while (std::getline(entries, entry, ',')) {
      names += (names.empty() ? "" : ",") + entry.substr(0, entry.find("->"));
    }
    return "{" + names + "}";
  }
  return type.substr(0, type.find(':'));
}

// Help without the library's noise: no "{false}" after a flag's names, enum
// names without their numbers, no validator names after a type.
class PlainFormatter : public CLI::Formatter {
 public:
  std::string make_option_name(const CLI::Option* option, bool positional) const override {
    if (positional) return CLI::Formatter::make_option_name(option, positional);
    std::string name = option->get_name(false, true), plain;
    int depth = 0;
    for (char c : name) {  // drop "{...}" defaults of flags
      depth += c == '{';
      if (depth == 0) plain += c;
      depth -= c == '}' && depth > 0;
    }
    return plain;
  }
  std::string make_option_opts(const CLI::Option* option) const override {
    if (!option->get_option_text().empty()) return " " + option->get_option_text();
    std::string out;
    if (option->get_type_size() != 0) {  // flags show no value
      if (!option->get_type_name().empty()) out += " " + PlainTypeName(option->get_type_name());
      if (!option->get_default_str().empty()) out += "=" + option->get_default_str();
      if (option->get_expected_max() == CLI::detail::expected_max_vector_size) out += " ...";
      if (option->get_required()) out += " (required)";
    }
    if (!option->get_envname().empty()) out += " (env " + option->get_envname() + ")";
    return out;
  }
};

void UsePlainHelp(CLI::App* app, const std::shared_ptr<CLI::Formatter>& formatter) {
  app->formatter(formatter);
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; }))
    UsePlainHelp(sub, formatter);
}

}  // namespace

std::optional<int> ParseCommandLine(CLI::App* app, int argc, char** argv) {
  CheckSeedsAreUnsigned(app);
  UsePlainHelp(app, std::make_shared<PlainFormatter>());
  try {
    app->parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    // --help and --version print as CLI11 prints them; a mistake is one
    // line with the command's prefix, as every other error is.
    if (error.get_exit_code() == 0) return app->exit(error);
    std::fprintf(stderr,
                 "%s: error: %s (see --help)\n",
                 app->get_name().c_str(),
                 PrintableText(error.what()).c_str());
    return 2;
  }
  return std::nullopt;
}

void AddFusePlanarFlag(CLI::App* app, bool* planar) {
  app->add_flag("--fuse-planar",
                *planar,
                "With --fuse-register: correct the poses in x, y and yaw only (point-to-plane "
                "ICP), for floor-aligned poses of a ground robot");
}

namespace {

// The vote network's training rooms: how many, what is in them, where they are kept.
void AddVoteNetRoomFlags(CLI::App* app, VoteNetTrainingOptions* options) {
  VoteNetTrainingOptions& o = *options;
  app->add_option("--vote-rooms", o.rooms, "Vote network: generated training rooms")
      ->capture_default_str();
  app->add_option("--vote-frames", o.frames_per_room, "Vote network: frames per training room")
      ->capture_default_str();
  app->add_option("--vote-size-jitter",
                  o.room.size_jitter,
                  "Vote network: per-side size jitter of the training rooms' furniture (0..0.5)")
      ->capture_default_str();
  app->add_option("--vote-max-clutter",
                  o.room.max_clutter,
                  "Vote network: most clutter pieces per training room (at least one; issue 69)")
      ->capture_default_str();
  app->add_option("--vote-clutter-side",
                  o.room.max_clutter_side_m,
                  "Vote network: longest footprint side of the training rooms' clutter (m; "
                  "larger lets beds, long shelves and kitchen runs in)")
      ->capture_default_str();
  app->add_option("--vote-surface-clutter",
                  o.room.surface_clutter,
                  "Vote network: share of the training rooms' tables and sideboards with small "
                  "clutter on top (0..1)")
      ->capture_default_str();
  app->add_option("--vote-shape-variety",
                  o.shape_variety,
                  "Vote network: procedural tables and sideboards per class (four-leg, pedestal, "
                  "trestle; doors, drawers, shelves) mixed into the training rooms, sized within "
                  "the catalog's range (0: none)")
      ->capture_default_str();
  app->add_option("--vote-fused-share",
                  o.fused_share,
                  "Vote network: the share of training frames seen with their room's other "
                  "frames fused in, as 'detect --fuse' sees a place (0..1; 0: each frame alone)")
      ->capture_default_str();
  app->add_option_function<std::string>(
      "--vote-fused-pose-noise",
      [options](const std::string& text) {
        FrameFusion fusion;
        ParsePoseNoise(text, &fusion, "--vote-fused-pose-noise");
        options->fused_pose_noise_m = fusion.pose_noise_m;
        options->fused_pose_noise_deg = fusion.pose_noise_deg;
        options->fused_planar_noise = fusion.planar_noise;
      },
      "M,DEG[,planar]: with --vote-fused-share, the fused frames' room-mates with a random "
      "pose error of sigma M metres along and DEG degrees about each axis (planar: along x "
      "and y and about z only), as '--fuse-pose-noise' draws it; default exact poses");
  AddEnumOption(app,
                "--vote-shape-sizes",
                &o.shape_sizes,
                "Vote network: the varied models' sizes: the catalog's range, or real (widened "
                "to the class's usual sizes, a fifth of the tables under a cloth)");
  app->add_flag("--keep-rooms",
                o.keep_rooms,
                "Keep the vote network's training rooms (<model>.rooms.db) for reuse");
  app->add_option("--rooms-cache",
                  o.rooms_cache,
                  "Vote network: keep the training rooms in this directory by what decides "
                  "them (catalog, held-out models, seed, room count, sensor) and reuse them in "
                  "any later training of the same rooms, e.g. another network on one fold");
}

// The vote network itself and its targets (stored with the weights).
void AddVoteNetNetworkFlags(CLI::App* app, VoteNetTrainingOptions* options) {
  VoteNetTrainingOptions& o = *options;
  app->add_option("--vote-width", o.net.width, "Vote network: channels of its first level")
      ->capture_default_str();
  app->add_option("--vote-levels",
                  o.net.levels,
                  "Vote network: halvings of its encoder (receptive field; stored in the model)")
      ->capture_default_str();
  app->add_option("--vote-range",
                  o.net.range_m,
                  "Vote network: the scan's points within this distance of the sensor are "
                  "rasterised (m; stored in the model, detection uses the same)")
      ->capture_default_str();
  app->add_option("--vote-centre-radius",
                  o.net.coder.centre_radius_cells,
                  "Vote network: the cells within this distance of a piece's centre cell "
                  "regress its box as the centre cell does (cells, 0..10; 0: the centre cell "
                  "alone; without --vote-dense)")
      ->capture_default_str();
  app->add_flag_callback(
      "--vote-dense",
      [options] { options->net.coder = BevCoderOptions::Dense(); },
      "Vote network: dense votes (every cell of a piece votes for its centre, decoded by the "
      "votes' mean shift; fixed heat width, ignore regions) instead of the centre cell alone");
  app->add_flag_callback(
      "--vote-edges",
      [options] { options->net.coder.edge_votes = true; },
      "Vote network: edge votes (every cell of a piece regresses its distances to the four "
      "sides of the piece's box; detection centres tables, sideboards and sofas between the "
      "sides their cells place)");
}

// How the vote network is trained: epochs, batches, rate, the weights kept, seed, threads.
void AddVoteNetScheduleFlags(CLI::App* app, VoteNetTrainingOptions* options) {
  VoteNetTrainingOptions& o = *options;
  app->add_option("--vote-epochs", o.epochs, "Vote network: passes over the frames")
      ->capture_default_str();
  app->add_option("--vote-batch", o.batch_size, "Vote network: frames per training step")
      ->capture_default_str();
  app->add_option("--vote-lr", o.learning_rate, "Vote network: peak learning rate (Adam)")
      ->capture_default_str();
  app->add_option("--vote-average",
                  o.weight_average,
                  "Vote network: keep the exponential moving average of its weights over the "
                  "steps with this decay (e.g. 0.999; 0: the last step's weights)")
      ->capture_default_str();
  app->add_flag("--vote-keep-last-weights",
                o.keep_last_weights,
                "Vote network: with --vote-average, also write the last step's weights as "
                "<model>.last.fcm (to measure the average against them)");
  app->add_option("--vote-seed", o.seed, "Vote network: seed of rooms, weights and batches")
      ->capture_default_str();
  app->add_option("--vote-member",
                  o.member,
                  "Vote network: train member K of an ensemble (its own weights and batches, "
                  "the same rooms; 0: the plain network); combine with 'model ensemble'")
      ->capture_default_str();
  app->add_option("--vote-ensemble",
                  o.ensemble,
                  "Vote network: train this many networks on the same rooms (each its own "
                  "weights; the training time times N) and average them in detection")
      ->capture_default_str();
  app->add_option("--vote-threads", o.threads, "Vote network: torch threads while training")
      ->capture_default_str();
  AddEnumOption(app,
                "--vote-precision",
                &o.precision,
                "Vote network: the arithmetic of its training: auto (bf16 on a CPU with "
                "AMX-BF16, else fp32), fp32 or bf16");
}

}  // namespace

void AddVoteNetFlags(CLI::App* app, VoteNetFlags* flags) {
  app->add_flag("--vote-net,!--no-vote-net",
                flags->enabled,
                "Train the learned vote map (generated rooms, a CNN) into the model (the "
                "default); --no-vote-net: the codebook alone");
  AddVoteNetRoomFlags(app, &flags->options);
  app->add_option("--vote-sensor",
                  flags->sensor_file,
                  "Vote network: render its training rooms with this sensor file's Kinect model "
                  "(dataset noise --fit --out; default: the published model)");
  AddVoteNetNetworkFlags(app, &flags->options);
  AddVoteNetScheduleFlags(app, &flags->options);
}

const VoteNetTrainingOptions* VoteNetFlags::Resolve(bool quiet) {
  if (!enabled) return nullptr;
  if (!sensor_file.empty()) options.sensor = ReadSensorFile(sensor_file);
  options.quiet = quiet;
  options.Check();
  return &options;
}

}  // namespace furn
