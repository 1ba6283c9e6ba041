// Protocol C of SPEC.md §9 (the paper's Table I): classify part subsets of
// held-out views by their nearest neighbour's CAD model. 80/20 splits by view,
// repeated; mean and standard deviation of CAD-model and category accuracy,
// and the category confusion matrix summed over repetitions.
//
//   PartEvaluation result = EvaluatePartSubsets(catalog, model, PartEvaluationOptions{});
#pragma once

#include <string>
#include <vector>

#include "core/part_subsets.h"
#include "core/trainer.h"
#include "scenes/catalog.h"
#include "workbench/train_command.h"

namespace furn {

struct PartEvaluationOptions {
  ScanOptions scan;
  PartSubsetOptions subsets;
  int repetitions = 10;        // (1..100)
  double test_fraction = 0.2;  // of the views (0..1)
  int neighbours = 1;          // k of the k-NN vote; a tie goes to the nearer neighbour (1..50)
  uint64_t seed = 1;
};

struct PartEvaluation {
  int views = 0;
  int subsets = 0;
  std::vector<double> model_accuracy;     // per repetition
  std::vector<double> category_accuracy;  // per repetition
  double model_mean = 0, model_std = 0, category_mean = 0, category_std = 0;
  std::vector<std::string> classes;
  std::vector<std::vector<int64_t>> confusion;  // rows true class, columns predicted
};

// Rescans the model file's CAD models (by name, from `catalog`) with its own
// segmentation options. Throws InputError for a model the catalog lacks.
PartEvaluation EvaluatePartSubsets(const Catalog& catalog,
                                   const TrainedModel& model,
                                   const PartEvaluationOptions& options);

// parts.json and confusion.png in `out_dir`.
void WritePartEvaluation(const PartEvaluation& result, const std::string& out_dir);

}  // namespace furn
