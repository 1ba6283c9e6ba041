// workbench: the command-line front end. One binary, subcommands from a table
// (as `colmap <command>`); each RunX only parses flags and calls library code.
//
//   workbench catalog list --catalog default
//   workbench catalog export Scopia/chair3 --out chair.ply
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "core/util/leak_suppressions.h"
#include "core/util/parallel.h"
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
      "usage: workbench [--threads N] <command> [options]   (workbench <command> "
      "--help; workbench --version)\n\n"
      "--threads N: worker threads of the whole run (default: FURN_THREADS, else the CPUs\n"
      "  this process may use: its affinity mask, capped by SLURM_CPUS_PER_TASK)\n\n"
      "commands:\n");
  for (const Command& command : kCommands) std::printf("  %-10s %s\n", command.name, command.help);
  std::printf(
      "\nprotocols (docs/evaluation.md): A the paper's detection (maxima within 5 cm, threshold\n"
      "  swept), B detection AP by centre distance (and box IoU), C the paper's part-subset\n"
      "  classification, D k-means against RIM vocabularies, E leave-models-out (furniture\n"
      "  never trained on)\n");
}

// `--threads N` or `--threads=N` in front of the command: the pool's size,
// removed from argv. Returns false (after one line on stderr) for a bad one.
bool TakeThreadsFlag(int* argc, char*** argv) {
  if (*argc < 2) return true;
  const std::string first = (*argv)[1];
  std::string value;
  int used = 0;
  if (first == "--threads") {
    if (*argc < 3) {
      std::fprintf(stderr, "workbench: --threads needs a count (e.g. --threads 2)\n");
      return false;
    }
    value = (*argv)[2];
    used = 2;
  } else if (first.rfind("--threads=", 0) == 0) {
    value = first.substr(10);
    used = 1;
  } else {
    return true;
  }
  char* end = nullptr;
  const long threads = std::strtol(value.c_str(), &end, 10);
  if (value.empty() || *end != '\0' || threads < 1 || threads > furn::kMaxParallelThreads) {
    std::fprintf(stderr,
                 "workbench: --threads '%s' must be a whole number in 1..%d\n",
                 furn::PrintableText(value).c_str(),
                 furn::kMaxParallelThreads);
    return false;
  }
  furn::SetParallelThreads(static_cast<int>(threads));
  (*argv)[used] = (*argv)[0];
  *argv += used;
  *argc -= used;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (!TakeThreadsFlag(&argc, &argv)) return 2;
  try {  // a bad FURN_THREADS is a usage error, before any work
    furn::ParallelThreads();
  } catch (const std::exception& error) {
    std::fprintf(stderr, "workbench: %s\n", furn::PrintableText(error.what()).c_str());
    return 2;
  }
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    PrintUsage();
    return argc < 2 ? 2 : 0;
  }
  if (std::strcmp(argv[1], "--version") == 0) {
    std::printf("workbench (furnidet) %s\n", FURN_VERSION);
    const int cpus = furn::AvailableCpus();
    std::printf("threads: %d (from %s; %d CPU%s available to this process)\n",
                furn::ParallelThreads(),
                furn::ParallelThreadsSource(),
                cpus,
                cpus == 1 ? "" : "s");
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
