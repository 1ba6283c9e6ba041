#include "workbench/cli_common.h"

#include <CLI/CLI.hpp>
#include <cstdlib>

#include "core/progress.h"

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
  app->add_option("--data-dir", flags->data_dir, "Directory of class_map.json (env FURN_DATA_DIR)")
      ->capture_default_str();
  app->add_flag("--quiet,-q", flags->quiet, "No progress output");
}

void ApplyGlobalFlags(const CatalogFlags& flags) { Progress::SetQuiet(flags.quiet); }

CatalogOpenOptions MakeOpenOptions(const CatalogFlags& flags) {
  CatalogOpenOptions options;
  options.catalog_dir = flags.catalog_dir;
  options.data_dir = flags.data_dir;
  return options;
}

std::optional<int> ParseCommandLine(CLI::App* app, int argc, char** argv) {
  try {
    app->parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app->exit(error) == 0 ? 0 : 2;
  }
  return std::nullopt;
}

}  // namespace furn
