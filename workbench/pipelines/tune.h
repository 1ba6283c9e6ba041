// `workbench tune` (SPEC.md §11): grid or random search over training and
// detection options on a validation split. The search space is a JSON file
// from option paths (as in an options file) to the values to try:
//
//   {"trainer.region_growing.delta_m": [0.03, 0.05, 0.08],
//    "detector.relative_threshold": {"min": 0.05, "max": 0.3, "steps": 6},
//    "detector.cell_m": {"min": 0.01, "max": 0.05, "log": true},
//    "trainer.vocabulary.kind": ["rim", "kmeans"]}
//
// A list is tried value by value; a range is cut into `steps` values for the
// grid (default 3, log-spaced with "log") and drawn uniformly (or
// log-uniformly) by random search, as integers when min and max are.
// Trial 0 always runs the base options. Every trial is an evaluation run in
// the dataset (kind "tune"); trainer options that differ from the base train
// a model once, cached by the options' hash. A rerun of the same command
// skips the trials it finds. The best trial is evaluated again on the test
// split, and the report and best_options.json go to the output folder.
//
//   TuneOptions options;
//   options.db_path = "synth.db";
//   options.space_path = "tune.json";
//   const TuneSummary summary = RunTuning(catalog, options);
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/detector/detector.h"
#include "scenes/catalog.h"
#include "workbench/formats/options_file.h"

namespace furn {

enum class TuneStrategy { kGrid, kRandom };

struct TuneParameter {
  std::string path;                 // "trainer.region_growing.delta_m", "detector.cell_m"
  std::vector<std::string> values;  // a list: each value as JSON text
  bool is_range = false;            // else: min, max, steps, log, integer
  double min = 0, max = 0;
  int steps = 3;
  bool log = false;
  bool integer = false;
};

struct TuneSpace {
  std::vector<TuneParameter> parameters;  // in the file's order
};

// Throws InputError naming `what` and the parameter for: not JSON, an empty
// space, an unknown option path, an empty list, a range with min > max,
// steps < 1, a log range that is not positive.
TuneSpace ParseTuneSpace(const std::string& text, const std::string& what);

struct TuneTrial {
  int index = 0;                    // 0: the base options
  std::vector<std::string> values;  // per parameter, JSON text
  TrainingOptions training;
  DetectorOptions detector;
};

// The trials to run, `count` in all with trial 0 the base options: the grid
// points (in a seeded order when there are more than fit) or random draws;
// a point equal to an earlier one is not repeated. Every trial's options are
// built and Check()ed here, so a value out of range is an InputError naming
// the trial and the option before anything runs.
std::vector<TuneTrial> MakeTrials(const TuneSpace& space,
                                  TuneStrategy strategy,
                                  int count,
                                  uint64_t seed,
                                  const TrainingOptions& base_training,
                                  const DetectorOptions& base_detector);

struct TuneOptions {
  std::string db_path;
  std::string space_path;
  std::string work_dir;  // trained models: <work_dir>/models/<hash>.fcm (locks: <work_dir>/locks)
  std::string out_dir;   // index.html, plots, best_options.json
  std::string base_options_path;  // options file the trials start from ("": defaults)
  // The trials' base detector options, when given (the CLI's detector flags
  // over the file); unset: the file's, or the defaults.
  std::optional<DetectorOptions> base_detector;
  std::string base_model_path;  // optional: a model trained with the base trainer options
  std::string catalog_spec = "default";
  std::string split = "val";        // where trials are scored
  std::string test_split = "test";  // where the best is checked ("" or "none": skipped)
  int trials = 20;                  // including the base (>= 1)
  TuneStrategy strategy = TuneStrategy::kRandom;
  uint64_t seed = 1;
  int max_frames = 0;                  // per evaluation (0: the whole split)
  std::string objective = "mAP@10cm";  // a run metric, higher is better
  double max_ms = 0;                   // median latency constraint (0: none)
  // Detector (RANSAC) seeds each trial is evaluated with; its metrics are the
  // mean over them (1..20). One run per seed.
  int seeds = 1;
  // Tune as a Slurm array job (issue 31). A task (trial_shards > 0) runs only
  // trials t with t % trial_shards == trial_shard on the validation split and
  // writes each (trial, seed) as a shard file into results_dir, storing no run
  // and writing no report. The final job (results_dir set, trial_shards 0)
  // stores those files as the trials' runs instead of evaluating them, then
  // ranks, checks the best on the test split and writes the report as usual.
  int trial_shard = 0, trial_shards = 0;
  std::string results_dir;

  // Throws InputError naming the field and the rule.
  void Check() const;
};

struct TuneSummary {
  std::string tune_id;  // 16 hex digits: what identifies the search for resuming
  int trials = 0, trials_resumed = 0, models_trained = 0;
  int best_index = 0;
  int64_t best_run = 0;
  std::map<std::string, double> base_validation, best_validation, base_test, best_test;
  std::string best_options_path, report_path;
};

TuneSummary RunTuning(const Catalog& catalog, const TuneOptions& options);

// Everything RunTuning checks before it trains or evaluates (the space, the
// objective, the trials' options, the base model, the dataset), without
// running anything: what `tune --shards` checks before it submits a job.
void CheckTuning(const Catalog& catalog, const TuneOptions& options);

}  // namespace furn
