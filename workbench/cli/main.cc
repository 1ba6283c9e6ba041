// workbench: the command-line front end. One binary, subcommands from a table
// (as `colmap <command>`); each RunX only parses flags and calls library code.
//
//   workbench catalog list --catalog default
//   workbench catalog export Scopia/chair3 --out chair.ply
#include <cstdio>
#include <cstring>
#include <exception>

#include "core/util/leak_suppressions.h"
#include "core/util/text.h"
#include "workbench/cli/commands.h"

namespace {

struct Command {
  const char* name;
  int (*run)(int argc, char** argv);
  const char* help;
};

constexpr Command kCommands[] = {
    {"catalog", furn::RunCatalog, "list, show, export and draw CAD catalog entries"},
    {"render", furn::RunRender, "render one model as ideal and noisy Kinect v1 depth"},
    {"generate",
     furn::RunGenerate,
     "compose rooms, render Kinect frames, store ground truth in SQLite"},
    {"dataset", furn::RunDataset, "info, preview, merge and export dataset databases"},
    {"train", furn::RunTrain, "learn the part vocabulary and shape model from virtual scans"},
    {"model", furn::RunModel, "describe a trained model file"},
    {"eval-parts", furn::RunEvalParts, "protocol C: part-subset classification accuracy"},
    {"detect", furn::RunDetect, "detect furniture in a depth scan (cloud, depth PNG, DB frame)"},
    {"evaluate", furn::RunEvaluate, "detect over a dataset split; metrics stored as a run"},
    {"crossval",
     furn::RunCrossval,
     "protocol E: leave-models-out folds, trained and evaluated, mean and spread as a run"},
    {"regress", furn::RunRegress, "compare a run with a baseline; exit 1 when worse"},
    {"report", furn::RunReport, "HTML and PNG report of an evaluation run"},
    {"history", furn::RunHistory, "every metric across runs and commits, plots and a table"},
    {"tune", furn::RunTune, "search training and detection options; trials stored as runs"},
    {"adapt",
     furn::RunAdapt,
     "fit a model's vote network to your own sensor from unlabelled scans (AdaBN)"},
    {"jobs", furn::RunJobs, "state of a Slurm array job's folder (status), or wait for it"},
};

void PrintUsage() {
  std::printf(
      "usage: workbench <command> [options]   (workbench <command> "
      "--help; workbench --version)\n\ncommands:\n");
  for (const Command& command : kCommands) std::printf("  %-10s %s\n", command.name, command.help);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    PrintUsage();
    return argc < 2 ? 2 : 0;
  }
  if (std::strcmp(argv[1], "--version") == 0) {
    std::printf("workbench (furnidet) %s\n", FURN_VERSION);
    return 0;
  }
  for (const Command& command : kCommands) {
    if (std::strcmp(command.name, argv[1]) != 0) continue;
    try {
      return command.run(argc - 1, argv + 1);
    } catch (const std::exception& error) {
      // One line whatever the message holds (names from files are data).
      std::fprintf(
          stderr, "workbench %s: error: %s\n", argv[1], furn::PrintableText(error.what()).c_str());
      return 1;
    }
  }
  std::fprintf(stderr,
               "workbench: unknown command '%s' (see workbench --help)\n",
               furn::PrintableText(argv[1]).c_str());
  return 2;
}
