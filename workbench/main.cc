// workbench: the command-line front end. One binary, subcommands from a table
// (as `colmap <command>`); each RunX only parses flags and calls library code.
//
//   workbench catalog list --catalog default
//   workbench catalog export Scopia/chair3 --out chair.ply
#include <cstdio>
#include <cstring>
#include <exception>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "workbench/commands.h"

namespace {

using Command = std::function<int(int, char**)>;

const std::vector<std::pair<std::string, std::pair<Command, std::string>>>&
Commands() {
  static const std::vector<
      std::pair<std::string, std::pair<Command, std::string>>>
      kCommands = {
          {"catalog",
           {furn::RunCatalog,
            "list, show, export and draw CAD catalog entries"}},
      };
  return kCommands;
}

void PrintUsage() {
  std::printf(
      "usage: workbench <command> [options]   (workbench <command> "
      "--help)\n\ncommands:\n");
  for (const auto& [name, command] : Commands()) {
    std::printf("  %-10s %s\n", name.c_str(), command.second.c_str());
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 ||
      std::strcmp(argv[1], "-h") == 0) {
    PrintUsage();
    return argc < 2 ? 2 : 0;
  }
  for (const auto& [name, command] : Commands()) {
    if (name != argv[1]) continue;
    try {
      return command.first(argc - 1, argv + 1);
    } catch (const std::exception& error) {
      std::fprintf(stderr, "workbench %s: error: %s\n", argv[1], error.what());
      return 1;
    }
  }
  std::fprintf(stderr,
               "workbench: unknown command '%s' (see workbench --help)\n",
               argv[1]);
  return 2;
}
