// Flags shared by several subcommands, so each is spelled and checked once.
#pragma once

#include <optional>
#include <string>

#include "scenes/catalog.h"

namespace CLI {
class App;
}

namespace furn {

struct CatalogFlags {
  std::string spec = "default";
  std::string catalog_dir = "/usr/share/sweethome3d/furniture";
  std::string data_dir = FURN_DEFAULT_DATA_DIR;
  bool quiet = false;
};

// --catalog, --catalog-dir, --data-dir, --quiet.
void AddCatalogFlags(CLI::App* app, CatalogFlags* flags);
// Applies --quiet (progress off) and the FURN_DATA_DIR environment override.
void ApplyGlobalFlags(const CatalogFlags& flags);
CatalogOpenOptions MakeOpenOptions(const CatalogFlags& flags);

// Parses the command line. Returns the exit code when the command should stop
// here: 0 after --help, 2 for every usage mistake (CLI11 prints the message).
std::optional<int> ParseCommandLine(CLI::App* app, int argc, char** argv);

}  // namespace furn
