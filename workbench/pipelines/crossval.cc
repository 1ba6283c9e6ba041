#include "workbench/pipelines/crossval.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/codebook/hypothesis_scorer.h"
#include "core/geometry/mesh.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "reports/run_results.h"
#include "scenes/model_folds.h"
#include "workbench/formats/json_text.h"
#include "workbench/pipelines/run_record.h"
#include "workbench/pipelines/train.h"

namespace furn {

DatasetFoldSpec ReadDatasetFolds(const std::string& db_path) {
  const std::optional<std::string> generation =
      DatasetDb(db_path, DatasetDb::Mode::kReadOnly).GenerationOptions();
  const std::string what = db_path + " (its generation options)";
  const nlohmann::json options =
      generation ? ParseUserJson<nlohmann::json>(*generation, what) : nlohmann::json::object();
  Require(options.is_object() && options.contains("model_folds"),
          db_path +
              ": was not generated with leave-models-out folds (make one with "
              "'workbench generate --model-folds 5 ...')");
  const nlohmann::json& folds = options["model_folds"];
  Require(folds.is_object() && folds.contains("folds") && folds["folds"].is_number_integer() &&
              folds["folds"] >= 2 && folds["folds"] <= 100,
          what + ": 'model_folds.folds' must be an integer in 2..100");
  Require(folds.contains("seed") && folds["seed"].is_number_unsigned(),
          what + ": 'model_folds.seed' must be a non-negative integer");
  return {folds["folds"].get<int>(), folds["seed"].get<uint64_t>()};
}

namespace {

// The folds the dataset was generated with (`generate --model-folds`).
ModelFolds DatasetFolds(const Catalog& catalog, const std::string& db_path, uint64_t* seed) {
  const DatasetFoldSpec spec = ReadDatasetFolds(db_path);
  *seed = spec.seed;
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadOnly);
  ModelFolds folds = AssignModelFolds(catalog, spec.count, spec.seed);
  // The same catalog must give the same split: every target of room k is a
  // model of fold k % K.
  for (int64_t room_id : dataset.RoomIds()) {
    for (const ObjectRecord& object : dataset.ReadRoom(room_id, /*with_images=*/false).objects) {
      if (!object.furniture_class) continue;
      const auto it = folds.fold_of_model.find(object.model_id);
      Require(it != folds.fold_of_model.end() && it->second == folds.FoldOfRoom(room_id),
              db_path + ": room " + std::to_string(room_id) + " has target " + object.model_id +
                  ", which catalog " + catalog.description() + " does not put in fold " +
                  std::to_string(folds.FoldOfRoom(room_id)) +
                  " (use the catalog the dataset was generated from)");
    }
  }
  return folds;
}

// A fold's model file: named by what decides it (trainer options, catalog,
// held-out models), so a second run reuses it.
std::string FoldModelPath(const Catalog& catalog,
                          const CrossvalOptions& options,
                          const std::set<std::string>& held_out,
                          int fold,
                          int folds) {
  std::string key = TrainingOptionsJson(options.training) + "\n" + catalog.description();
  if (options.vote_net) key += "\nvote net: " + options.vote_net->Json();
  for (const CatalogEntry* entry : catalog.Classified()) key += "\n" + entry->id;
  key += "\nheld out:";
  for (const std::string& id : held_out) key += "\n" + id;
  return (std::filesystem::path(options.work_dir) /
          ("fold-" + std::to_string(fold) + "-of-" + std::to_string(folds) + "-" +
           ShortHash(key, 12) + ".fcm"))
      .string();
}

// Mean and population standard deviation of each metric over the folds that
// have it (a fold may lack a class's AP when none of its objects is visible).
void Aggregate(CrossvalSummary* summary) {
  std::map<std::string, std::vector<double>> values;
  for (const CrossvalFold& fold : summary->per_fold) {
    for (const auto& [name, value] : fold.evaluation.result.metrics) {
      if (std::isfinite(value)) values[name].push_back(value);
    }
  }
  for (const auto& [name, v] : values) {
    double mean = 0, square = 0;
    for (double x : v) mean += x / v.size();
    for (double x : v) square += (x - mean) * (x - mean) / v.size();
    summary->mean[name] = mean;
    summary->spread[name] = std::sqrt(square);
  }
  // Sizes are totals, not means.
  for (const std::string& total : {MetricId::Plain(PlainMetric::kFrames).Name(),
                                   MetricId::Plain(PlainMetric::kObjects).Name(),
                                   MetricId::Plain(PlainMetric::kFramesWithoutPoints).Name()}) {
    if (!values.count(total)) continue;
    double sum = 0;
    for (double x : values[total]) sum += x;
    summary->mean[total] = sum;
    summary->spread.erase(total);
  }
}

// Fold k's evaluation: its rooms only, stored as a "crossval-fold" run.
EvaluateCommandOptions FoldEvaluation(const CrossvalOptions& options, int fold, int folds) {
  EvaluateCommandOptions evaluate = options.evaluate;
  evaluate.fold = fold;
  evaluate.fold_count = folds;
  evaluate.kind = "crossval-fold";
  evaluate.label = "fold " + std::to_string(fold) + " of " + std::to_string(folds);
  return evaluate;
}

}  // namespace

namespace {

// Fold k's model trained (or reused) without its models, then evaluated:
// with the fixed gates collecting scorer samples when a scorer is to be
// learnt, else as the fold's run.
// Fold k's model: trained without the fold's models, or reused when a model
// of the same inputs exists.
CrossvalFold TrainFold(const Catalog& catalog,
                       const CrossvalOptions& options,
                       const ModelFolds& folds,
                       int k) {
  CrossvalFold fold;
  fold.fold = k;
  const std::set<std::string> held_out = folds.ModelsOf(k);
  for (const std::string& id : held_out)
    ++fold.held_out_per_class[ClassName(*catalog.Get(id).furniture_class)];
  fold.model_path = FoldModelPath(catalog, options, held_out, k, folds.count);
  fold.model_reused = std::filesystem::exists(fold.model_path);
  if (!options.quiet) {
    std::fprintf(stderr,
                 "crossval: fold %d of %d: %zu models held out; %s\n",
                 k + 1,
                 folds.count,
                 held_out.size(),
                 fold.model_reused ? "model reused" : "training");
  }
  if (!fold.model_reused) {
    TrainFromCatalog(catalog,
                     options.training.scan,
                     options.training.trainer,
                     fold.model_path,
                     held_out,
                     "",
                     options.vote_net ? &*options.vote_net : nullptr);
  }
  return fold;
}

CrossvalFold TrainAndEvaluateFold(const Catalog& catalog,
                                  const std::string& db_path,
                                  const CrossvalOptions& options,
                                  const ModelFolds& folds,
                                  int k,
                                  std::vector<ScorerSample>* samples) {
  CrossvalFold fold = TrainFold(catalog, options, folds, k);
  EvaluateCommandOptions evaluate = FoldEvaluation(options, k, folds.count);
  if (options.LearnsScorer()) {
    evaluate.kind = "crossval-gates";
    evaluate.detector.use_scorer = false;
    evaluate.collect_scorer_samples = true;
    fold.gates = EvaluateModel(fold.model_path, db_path, evaluate);
    *samples = std::move(fold.gates.scorer_samples);
  } else {
    fold.evaluation = EvaluateModel(fold.model_path, db_path, evaluate);
  }
  return fold;
}

// Nested: fold k's scorer learns from the other folds' hypotheses only, and
// fold k is evaluated again with it (or keeps the fixed gates when they are
// too few).
void ScoreFold(const std::string& db_path,
               const CrossvalOptions& options,
               int k,
               int folds,
               const std::vector<std::vector<ScorerSample>>& samples,
               CrossvalFold* fold) {
  std::vector<ScorerSample> others;
  for (int j = 0; j < folds; ++j) {
    if (j != k) others.insert(others.end(), samples[j].begin(), samples[j].end());
  }
  if (!options.quiet) {
    std::fprintf(stderr,
                 "crossval: fold %d of %d: scorer from %zu hypotheses of the other folds\n",
                 k + 1,
                 folds,
                 others.size());
  }
  if (!HypothesisScorer::CanTrain(others)) {  // too small a dataset: the fixed gates
    std::fprintf(stderr,
                 "warning: crossval fold %d: %zu hypotheses of the other folds are too few to "
                 "learn a scorer (20 with both labels needed); this fold uses the fixed "
                 "gates\n",
                 k,
                 others.size());
    fold->evaluation = fold->gates;
    return;
  }
  TrainedModel model = LoadTrainedModel(fold->model_path);
  model.scorer = HypothesisScorer::Train(others, options.scorer_options).Serialize();
  const std::string scored_path =
      (std::filesystem::path(options.work_dir) /
       ("fold-" + std::to_string(k) + "-of-" + std::to_string(folds) + "-scored.fcm"))
          .string();
  SaveTrainedModel(model, scored_path);
  EvaluateCommandOptions evaluate = FoldEvaluation(options, k, folds);
  evaluate.detector.use_scorer = true;
  fold->evaluation = EvaluateModel(scored_path, db_path, evaluate);
}

// Reliability bins pooled over the folds.
std::vector<CalibrationBin> PooledCalibration(const std::vector<CrossvalFold>& folds) {
  std::vector<CalibrationBin> calibration;
  for (const CrossvalFold& fold : folds) {
    const std::vector<CalibrationBin>& bins = fold.evaluation.result.calibration;
    if (calibration.empty()) {
      calibration = bins;
      continue;
    }
    for (size_t b = 0; b < bins.size() && b < calibration.size(); ++b) {
      calibration[b].detections += bins[b].detections;
      calibration[b].true_positives += bins[b].true_positives;
      calibration[b].score_sum += bins[b].score_sum;
    }
  }
  return calibration;
}

// The "crossval" run: its options, the folds' metrics and the pooled
// calibration; the mean, spread and fixed-gate metrics.
int64_t WriteCrossvalRun(const std::string& db_path,
                         const CrossvalOptions& options,
                         const CrossvalSummary& summary,
                         const std::vector<int64_t>& fold_runs) {
  RunRecord run = NewRunRecord("crossval",
                               options.evaluate.label.empty()
                                   ? "leave-models-out, " + std::to_string(summary.folds) + " folds"
                                   : options.evaluate.label);
  run.model_path = options.work_dir;
  run.split = options.evaluate.split;
  nlohmann::ordered_json stored{
      {"protocol", "leave-models-out"},
      {"folds", summary.folds},
      {"fold_seed", summary.fold_seed},
      {"fold_runs", fold_runs},
      {"trainer", nlohmann::json::parse(TrainingOptionsJson(options.training))},
      {"scorer",
       options.LearnsScorer()
           ? nlohmann::json{{"trees", options.scorer_options.trees},
                            {"max_depth", options.scorer_options.max_depth},
                            {"min_sample_count", options.scorer_options.min_sample_count},
                            {"calibration_share", options.scorer_options.calibration_share},
                            {"samples", summary.scorer_samples}}
           : nlohmann::json()},
      {"detector", nlohmann::json::parse(DetectorOptionsJson(options.evaluate.detector))}};
  if (options.vote_net) stored["vote_net"] = nlohmann::json::parse(options.vote_net->Json());
  if (options.evaluate.fusion.room_frames) stored["fusion"] = options.evaluate.fusion.Json();
  run.options_json = stored.dump();
  RunResults results;
  results.kind = RunResults::Kind::kCrossval;
  results.calibration = PooledCalibration(summary.per_fold);
  for (const CrossvalFold& fold : summary.per_fold) {
    results.folds.push_back({fold.fold,
                             fold.evaluation.run_id,
                             fold.held_out_per_class,
                             fold.evaluation.result.metrics});
  }
  run.results_json = results.Json();
  std::map<std::string, double> metrics = summary.mean;
  const auto in = [](const std::string& name, MetricId::Group group) {
    return MetricId::Parse(name).InGroup(group).Name();
  };
  for (const auto& [name, value] : summary.spread)
    metrics[in(name, MetricId::Group::kSpread)] = value;
  metrics[MetricId::Plain(PlainMetric::kFolds).Name()] = summary.folds;
  for (const auto& [name, value] : summary.gates)
    metrics[in(name, MetricId::Group::kGates)] = value;
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadWriteExisting);
  return dataset.WriteRun(run, metrics, {}, {});
}

}  // namespace

CrossvalSummary RunLeaveModelsOut(const Catalog& catalog,
                                  const std::string& db_path,
                                  const CrossvalOptions& options) {
  Require(!options.work_dir.empty(), "crossval needs a work directory for the fold models");
  const auto start = std::chrono::steady_clock::now();
  CrossvalSummary summary;
  const ModelFolds folds = DatasetFolds(catalog, db_path, &summary.fold_seed);
  summary.folds = folds.count;
  std::filesystem::create_directories(options.work_dir);
  if (options.train_only_fold >= 0) {
    Require(options.train_only_fold < folds.count,
            "fold " + std::to_string(options.train_only_fold) + ": " + db_path + " has " +
                std::to_string(folds.count) + " folds (0.." + std::to_string(folds.count - 1) +
                ")");
    summary.per_fold.push_back(TrainFold(catalog, options, folds, options.train_only_fold));
    summary.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return summary;
  }
  std::vector<std::vector<ScorerSample>> samples(folds.count);
  for (int k = 0; k < folds.count; ++k)
    summary.per_fold.push_back(
        TrainAndEvaluateFold(catalog, db_path, options, folds, k, &samples[k]));
  const bool scorer = options.LearnsScorer();
  if (scorer) {
    std::vector<ScorerSample> all;
    for (const auto& fold_samples : samples)
      all.insert(all.end(), fold_samples.begin(), fold_samples.end());
    summary.scorer_samples = static_cast<int>(all.size());
    for (int k = 0; k < folds.count; ++k)
      ScoreFold(db_path, options, k, folds.count, samples, &summary.per_fold[k]);
    if (HypothesisScorer::CanTrain(all)) {
      summary.scorer_path = (std::filesystem::path(options.work_dir) / "scorer.yml").string();
      WriteFileAtomically(summary.scorer_path,
                          HypothesisScorer::Train(all, options.scorer_options).Serialize());
    }
  }
  std::vector<int64_t> fold_runs;
  for (const CrossvalFold& fold : summary.per_fold) fold_runs.push_back(fold.evaluation.run_id);
  Aggregate(&summary);
  if (scorer) {
    for (const CrossvalFold& fold : summary.per_fold) {
      for (const auto& [name, value] : fold.gates.result.metrics) {
        // mAP at every distance, seen and unseen, and AP per class.
        const MetricId id = MetricId::Parse(name);
        const bool ap = id.kind() == MetricId::Kind::kMeanAp ||
                        id.kind() == MetricId::Kind::kClassAp ||
                        id == MetricId::Plain(PlainMetric::kMeanApSeen) ||
                        id == MetricId::Plain(PlainMetric::kMeanApUnseen);
        if (ap) summary.gates[name] += value / summary.per_fold.size();
      }
    }
  }
  summary.run_id = WriteCrossvalRun(db_path, options, summary, fold_runs);
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace furn
