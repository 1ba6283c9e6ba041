#include "workbench/pipelines/compare_vocab.h"

#include <cmath>

#include "core/util/error.h"
#include "workbench/pipelines/train.h"

namespace furn {

void CompareVocabularies(const Catalog& catalog,
                         const std::string& db_path,
                         const std::string& work_dir,
                         int seeds,
                         EvaluateCommandOptions options,
                         const std::function<void(const VocabularyRun&)>& on_run,
                         const std::function<void(const VocabularyMean&)>& on_vocabulary) {
  Require(seeds >= 1 && seeds <= 20, "--seeds must be in 1..20");
  Require(!work_dir.empty(), "--compare-vocab needs --work-dir for the trained models");
  struct Variant {
    const char* name;
    VocabularyKind kind;
    RimInit init;
  };
  const Variant variants[] = {{"kmeans", VocabularyKind::kKMeans, RimInit::kKMeans},
                              {"rim-kmeans-init", VocabularyKind::kRim, RimInit::kKMeans},
                              {"rim-pca-init", VocabularyKind::kRim, RimInit::kPcaSplit}};
  for (const Variant& variant : variants) {
    std::vector<double> map10;
    for (int seed = 1; seed <= seeds; ++seed) {
      TrainerOptions trainer;
      trainer.vocabulary.kind = variant.kind;
      trainer.vocabulary.rim_init = variant.init;
      trainer.vocabulary.seed = static_cast<uint64_t>(seed);
      ScanOptions scan;
      scan.seed = trainer.vocabulary.seed;
      const std::string model = work_dir + "/" + variant.name + "-" + std::to_string(seed) + ".fcm";
      TrainFromCatalog(catalog, scan, trainer, model);
      options.kind = "compare-vocab";
      options.label = std::string(variant.name) + " seed " + std::to_string(seed);
      const EvaluateSummary summary = EvaluateModel(model, db_path, options);
      const auto& m = summary.result.metrics;
      VocabularyRun run{variant.name,
                        seed,
                        MetricOrNan(m, MetricId::MeanAp(0.10)),
                        MetricOrNan(m, MetricId::MeanAp(0.05)),
                        MetricOrNan(m, MetricId::PaperBestF1(FurnitureClass::kChair)),
                        summary.run_id};
      map10.push_back(run.map10);
      on_run(run);
    }
    double mean = 0, square = 0;
    for (double v : map10) mean += v / map10.size();
    for (double v : map10) square += (v - mean) * (v - mean) / map10.size();
    on_vocabulary({variant.name, mean, std::sqrt(square), seeds});
  }
}

}  // namespace furn
