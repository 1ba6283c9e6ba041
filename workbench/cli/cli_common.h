// Flags shared by several subcommands, so each is spelled and checked once.
#pragma once

#include <optional>
#include <string>

#include "core/util/data_dir.h"
#include "scenes/catalog.h"
#include "workbench/pipelines/train_vote_net.h"

namespace CLI {
class App;
}

namespace furn {

struct CatalogFlags {
  std::string spec = "default";
  std::string catalog_dir = "/usr/share/sweethome3d/furniture";
  std::string data_dir = DefaultDataDir();  // core/util/data_dir.h
  bool quiet = false;
};

// --catalog, --catalog-dir, --data-dir, --quiet.
void AddCatalogFlags(CLI::App* app, CatalogFlags* flags);
// Applies --quiet (progress off) and the FURN_DATA_DIR environment override.
void ApplyGlobalFlags(const CatalogFlags& flags);
CatalogOpenOptions MakeOpenOptions(const CatalogFlags& flags);

// The vote network's training (train, crossval): --vote-net / --no-vote-net
// (on by default), --vote-rooms, --vote-epochs, --vote-threads, --vote-seed,
// --vote-frames, --vote-width, --keep-rooms.
struct VoteNetFlags {
  bool enabled = true;
  VoteNetTrainingOptions options;
  std::string sensor_file;  // --vote-sensor: options.sensor read from it
  // The options, or null with --no-vote-net; quiet follows --quiet.
  const VoteNetTrainingOptions* Resolve(bool quiet);
};
void AddVoteNetFlags(CLI::App* app, VoteNetFlags* flags);

// --fuse-planar (detect, evaluate, crossval): registration in x, y and yaw only.
void AddFusePlanarFlag(CLI::App* app, bool* planar);

// Parses the command line. Returns the exit code when the command should stop
// here: 0 after --help, 2 for every usage mistake (CLI11 prints the message).
std::optional<int> ParseCommandLine(CLI::App* app, int argc, char** argv);

}  // namespace furn
