// `evaluate --compare-vocab` (protocol D): the three part vocabularies
// (k-means, RIM from k-means, RIM from a PCA split) over several seeds, each
// trained on the catalog and evaluated as a run of its own.
//
//   CompareVocabularies(catalog, "synth.db", "work/", 3, options,
//                       [](const VocabularyRun& run) { print(run); });
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "scenes/catalog.h"
#include "workbench/pipelines/evaluate.h"

namespace furn {

struct VocabularyRun {
  std::string vocabulary;  // kmeans, rim-kmeans-init, rim-pca-init
  int seed = 0;
  double map10 = 0, map5 = 0, chair_best_f1 = 0;
  int64_t run_id = 0;
};

struct VocabularyMean {
  std::string vocabulary;
  double map10_mean = 0, map10_spread = 0;  // over the seeds
  int seeds = 0;
};

// Models go to `work_dir` (required); `seeds` in 1..20. Calls `on_run` after
// each evaluation and `on_vocabulary` after each vocabulary's seeds.
void CompareVocabularies(const Catalog& catalog,
                         const std::string& db_path,
                         const std::string& work_dir,
                         int seeds,
                         EvaluateCommandOptions options,
                         const std::function<void(const VocabularyRun&)>& on_run,
                         const std::function<void(const VocabularyMean&)>& on_vocabulary);

}  // namespace furn
