#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <set>
#include <tuple>

#include "core/model/trained_model.h"
#include "core/util/error.h"
#include "reports/evaluation.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/cluster_flags.h"
#include "workbench/cli/commands.h"
#include "workbench/cli/detector_flags.h"
#include "workbench/pipelines/generate.h"  // ParseShard
#include "workbench/pipelines/tune.h"

namespace furn {

namespace {

// `tune` as an array job: task i evaluates trials t with t % N == i into the
// job folder (training the models they need into the shared --work-dir); the
// final job is the same tune, which stores those evaluations as the trials'
// runs, ranks them, checks the best on the test split and writes the report.
ArrayJob TuneArrayJob(const ClusterFlags& cluster,
                      const TuneOptions& options,
                      int argc,
                      char** argv) {
  Require(cluster.shards <= options.trials,
          "--shards " + std::to_string(cluster.shards) + ": more tasks than --trials " +
              std::to_string(options.trials) + " (one task runs one or more trials)");
  ArrayJob job = NewArrayJob(cluster, "tune");
  const std::string results = std::filesystem::absolute(cluster.job_dir).string() + "/trials";
  const std::set<std::string> drop = {"--trial-shard", "--results-dir"};
  job.task_command = TaskCommandLine(
      argc,
      argv,
      drop,
      "--quiet --trial-shard " + TaskShardArgument(job) + " --results-dir " + ShellQuote(results));
  job.final_command = TaskCommandLine(argc, argv, drop, "--results-dir " + ShellQuote(results));
  job.final_output = std::filesystem::absolute(options.out_dir).string() + "/best_options.json";
  return job;
}

void PrintTuneSummary(const TuneOptions& options, const TuneSummary& summary) {
  const MetricId objective = MetricId::Parse(options.objective);
  std::printf(
      "tune %s: %d trials (%d done before), %d models trained; best is trial %d (run %lld)\n",
      summary.tune_id.c_str(),
      summary.trials,
      summary.trials_resumed,
      summary.models_trained,
      summary.best_index,
      static_cast<long long>(summary.best_run));
  std::printf("  %s on %s: base %.3f, best %.3f\n",
              options.objective.c_str(),
              options.split.c_str(),
              MetricOrNan(summary.base_validation, objective),
              MetricOrNan(summary.best_validation, objective));
  if (!summary.base_test.empty()) {
    std::printf("  %s on %s: base %.3f, best %.3f\n",
                options.objective.c_str(),
                options.test_split.c_str(),
                MetricOrNan(summary.base_test, objective),
                MetricOrNan(summary.best_test, objective));
  }
  std::printf("wrote %s and %s\n", summary.best_options_path.c_str(), summary.report_path.c_str());
}

// The learned detector's space when the base model has a vote network (its
// thresholds, suppression and fit), else the codebook's thresholds.
std::string DefaultTuneSpace(const std::string& data_dir, const std::string& model_path) {
  const bool learned = !model_path.empty() && !LoadTrainedModel(model_path).vote_net.empty();
  return (std::filesystem::path(data_dir) /
          (learned ? "tune_learned_space.json" : "tune_detector_space.json"))
      .string();
}

// The search: dataset, space, report and cache folders, trials, strategy,
// splits, objective and bounds.
void AddSearchFlags(CLI::App* app_pointer, TuneOptions* options_pointer, std::string* strategy) {
  CLI::App& app = *app_pointer;
  TuneOptions& options = *options_pointer;
  app.add_option("--db", options.db_path, "Dataset database (trials are stored as runs)")
      ->required();
  app.add_option("--space",
                 options.space_path,
                 "Search space: JSON of option path -> values (default: the data folder's "
                 "tune_learned_space.json when --model has a vote network, else "
                 "tune_detector_space.json)");
  app.add_option("--out", options.out_dir, "Report folder (index.html, best_options.json)")
      ->required();
  app.add_option("--work-dir", options.work_dir, "Cache of trained models (models/<hash>.fcm)")
      ->required();
  app.add_option("--trials", options.trials, "Trials, the base options included")
      ->capture_default_str();
  app.add_option("--strategy", *strategy, "grid or random")->capture_default_str();
  app.add_option("--seed", options.seed, "Seed of the random search and grid sampling")
      ->capture_default_str();
  app.add_option("--split", options.split, "Split the trials are scored on")->capture_default_str();
  app.add_option("--test-split", options.test_split, "Split the best is checked on (none: skip)")
      ->capture_default_str();
  app.add_option("--max-frames", options.max_frames, "Frames per evaluation (0: all)")
      ->capture_default_str();
  app.add_option("--objective", options.objective, "Run metric to maximise")->capture_default_str();
  app.add_option("--max-ms", options.max_ms, "Median latency bound in ms (0: none)")
      ->capture_default_str();
  app.add_option("--seeds",
                 options.seeds,
                 "Detector seeds per trial; metrics are their mean (RANSAC makes one run noisy)")
      ->capture_default_str();
}

}  // namespace

int RunTune(int argc, char** argv) {
  CLI::App app{"Search training and detection options on a validation split; every trial is a run",
               "workbench tune"};
  TuneOptions options;
  std::string strategy = "random";
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  AddSearchFlags(&app, &options, &strategy);
  // --options FILE: the options the trials start from; detector flags on top.
  DetectorFlags detector_flags(&app, {"--seed"});
  app.add_option("--model",
                 options.base_model_path,
                 "A model trained with the base trainer options (saves training it again)");
  std::string trial_shard;
  app.add_option("--trial-shard",
                 trial_shard,
                 "i/N: evaluate only trials t with t % N == i into --results-dir (what each task "
                 "of 'tune --shards' does)");
  app.add_option("--results-dir",
                 options.results_dir,
                 "Where the tasks of 'tune --shards' put the trials' evaluations; without "
                 "--trial-shard: store them as runs and rank (the final job)");
  ClusterFlags cluster;
  AddClusterFlags(&app, &cluster);
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);
  cluster.Check();
  if (!trial_shard.empty())
    std::tie(options.trial_shard, options.trial_shards) = ParseShard(trial_shard);
  Require(strategy == "grid" || strategy == "random",
          "--strategy '" + strategy + "' must be grid or random");
  options.strategy = strategy == "grid" ? TuneStrategy::kGrid : TuneStrategy::kRandom;
  options.catalog_spec = catalog_flags.spec;
  if (options.space_path.empty()) {
    options.space_path = DefaultTuneSpace(catalog_flags.data_dir, options.base_model_path);
    if (!catalog_flags.quiet) std::printf("tune: search space %s\n", options.space_path.c_str());
  }
  options.base_options_path = detector_flags.options_file();
  options.base_detector = detector_flags.Resolve();
  options.Check();
  const Catalog catalog = OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags));
  if (cluster.Active()) {
    Require(trial_shard.empty() && options.results_dir.empty(),
            "--shards N runs --trial-shard and --results-dir itself; give neither");
    CheckTuning(catalog, options);  // before anything is submitted
    return RunArrayJob(cluster, TuneArrayJob(cluster, options, argc, argv));
  }
  const TuneSummary summary = RunTuning(catalog, options);
  if (options.trial_shards > 0) {
    std::printf("tune %s: trial shard %s: %d trials evaluated into %s\n",
                summary.tune_id.c_str(),
                trial_shard.c_str(),
                summary.trials,
                options.results_dir.c_str());
    return 0;
  }
  PrintTuneSummary(options, summary);
  return 0;
}

}  // namespace furn
