// Protocol C of SPEC.md §9 (the paper's Table I): classify held-out part
// subsets by their nearest neighbours' CAD model. 80/20 splits, repeated; mean
// and standard deviation of CAD-model and category accuracy, and the category
// and CAD-model confusion matrices summed over repetitions.
//
// Two splits: by view (every subset of a held-out view is tested, none of its
// parts is in the library: the stricter test, and the default), or by subset
// as the paper did ("80% of the data as training and 20% as testing", the
// data being the ~25000 subsets), where a tested subset shares parts, and so
// points, with library subsets of its own view.
//
//   PartEvaluation result = EvaluatePartSubsets(catalog, model, PartEvaluationOptions{});
#pragma once

#include <string>
#include <vector>

#include "core/codebook/part_subsets.h"
#include "core/codebook/trainer.h"
#include "core/model/trained_model.h"
#include "scenes/catalog.h"
#include "workbench/pipelines/train.h"

namespace furn {

enum class PartSplit { kByView, kBySubset };

// "view" or "subset"; throws InputError naming the text otherwise.
PartSplit ParsePartSplit(const std::string& text);
const char* PartSplitName(PartSplit split);

struct PartEvaluationOptions {
  ScanOptions scan;
  PartSubsetOptions subsets;
  PartSplit split = PartSplit::kByView;
  int repetitions = 10;        // (1..100)
  double test_fraction = 0.2;  // of the views or subsets (0..1)
  int neighbours = 1;          // k of the k-NN vote; a tie goes to the nearer neighbour (1..50)
  int index_dimensions = 48;   // principal components the search uses (1..308; 308: plain L2)
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
  PartSplit split = PartSplit::kByView;
  std::vector<std::string> model_names;               // the CAD models, in model order
  std::vector<std::vector<int64_t>> model_confusion;  // rows true model, columns predicted
};

// Rescans the model file's CAD models (by name, from `catalog`) with its own
// segmentation options. Throws InputError for a model the catalog lacks.
PartEvaluation EvaluatePartSubsets(const Catalog& catalog,
                                   const TrainedModel& model,
                                   const PartEvaluationOptions& options);

// parts.json and confusion.png in `out_dir`.
void WritePartEvaluation(const PartEvaluation& result, const std::string& out_dir);

}  // namespace furn
