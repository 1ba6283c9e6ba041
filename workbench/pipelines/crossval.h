// `workbench crossval`: protocol E (SPEC §9), leave-models-out
// generalisation. On a dataset generated with `generate --model-folds K`
// (room k's targets are the models of fold k % K only), for each fold k:
// train on the catalog without fold k's models, evaluate on fold k's rooms
// (protocol B), store that as a run (kind "crossval-fold"). Then one run of
// kind "crossval" holds every metric's mean over the folds under its own name
// and the spread (population standard deviation) as "spread/<name>", so
// `report`, `history` and `regress` work on it as on any run.
//
// With the learned scorer (on by default), each fold is first evaluated with
// the fixed gates (runs of kind "crossval-gates", their means stored as
// "gates/<name>"), collecting every fitted hypothesis with its label; fold
// k's scorer is then trained on the other folds' hypotheses only (their
// rooms hold none of fold k's furniture) and fold k evaluated with it. A
// scorer trained on every fold's hypotheses is written to
// <work-dir>/scorer.yml, for `train --scorer`.
//
//   CrossvalOptions options;
//   options.work_dir = "out/crossval";
//   const CrossvalSummary summary = RunLeaveModelsOut(catalog, "folds.db", options);
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "scenes/catalog.h"
#include "workbench/formats/options_file.h"
#include "workbench/pipelines/evaluate.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn {

struct CrossvalOptions {
  std::string work_dir;             // fold models, reused when their inputs are the same
  TrainingOptions training;         // how each fold's model is trained
  EvaluateCommandOptions evaluate;  // detector, split ("all" by default), ...
  bool scorer = true;               // learn a hypothesis scorer per fold (nested)
  // With a vote network (issue 30): each fold's model holds one trained on
  // rooms generated without the fold's models, and the folds are evaluated
  // with learned voting (no scorer: it learns from the codebook's fits).
  std::optional<VoteNetTrainingOptions> vote_net;
  ScorerOptions scorer_options;
  bool quiet = false;
  // >= 0: only train (or find) this fold's model and stop, no evaluation and
  // no run (a Slurm array task; the final `crossval` reuses the models).
  int train_only_fold = -1;

  CrossvalOptions() { evaluate.split = Split::kAll; }
  // Whether folds learn a scorer: asked for, and voting with the codebook.
  bool LearnsScorer() const { return scorer && !vote_net; }
};

struct CrossvalFold {
  int fold = 0;
  std::map<std::string, int> held_out_per_class;  // models held out of training
  std::string model_path;
  bool model_reused = false;
  EvaluateSummary evaluation;  // with the fold's scorer when there is one
  EvaluateSummary gates;       // with the fixed gates (scorer runs only)
};

struct CrossvalSummary {
  int folds = 0;
  uint64_t fold_seed = 0;
  std::vector<CrossvalFold> per_fold;
  std::map<std::string, double> mean, spread;  // over folds, per metric
  std::map<std::string, double> gates;         // mean mAP and AP with the fixed gates (scorer runs)
  int64_t run_id = 0;                          // the "crossval" run
  std::string scorer_path;                     // the all-folds scorer, when learnt
  int scorer_samples = 0;
  double seconds = 0;
};

// The leave-models-out folds a dataset was generated with (`generate
// --model-folds K`). Throws InputError naming the database when it has none
// or they are malformed.
struct DatasetFoldSpec {
  int count = 0;
  uint64_t seed = 0;
};
DatasetFoldSpec ReadDatasetFolds(const std::string& db_path);

// Throws InputError when the dataset was not generated with model folds, or
// when the catalog's folds disagree with the dataset's rooms (another catalog).
CrossvalSummary RunLeaveModelsOut(const Catalog& catalog,
                                  const std::string& db_path,
                                  const CrossvalOptions& options);

}  // namespace furn
