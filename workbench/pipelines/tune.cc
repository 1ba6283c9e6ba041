#include "workbench/pipelines/tune.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <tuple>

#include "core/geometry/mesh.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/random.h"
#include "db/dataset_db.h"
#include "reports/tune_report.h"
#include "workbench/formats/json_text.h"
#include "workbench/pipelines/evaluate.h"
#include "workbench/pipelines/evaluated_frame.h"
#include "workbench/pipelines/file_lock.h"
#include "workbench/pipelines/train.h"

namespace furn {
namespace {

using Json = nlohmann::ordered_json;

// {"trainer": ..., "detector": ...} of the given options: the tree every
// parameter path points into.
Json CombinedJson(const TrainingOptions& training, const DetectorOptions& detector) {
  return Json::parse(OptionsFileJson(training, detector));
}

// The node at a dotted path, or nullptr when there is none.
Json* Find(Json* root, const std::string& path) {
  Json* node = root;
  size_t start = 0;
  for (;;) {
    const size_t dot = path.find('.', start);
    const std::string key = path.substr(start, dot - start);
    if (!node->is_object() || !node->contains(key)) return nullptr;
    node = &(*node)[key];
    if (dot == std::string::npos) return node;
    start = dot + 1;
  }
}

// Options with the given parameter values set on the base; Check()ed, with
// errors naming `what`.
void BuildOptions(const Json& base,
                  const TuneSpace& space,
                  const std::vector<std::string>& values,
                  const std::string& what,
                  TrainingOptions* training,
                  DetectorOptions* detector) {
  Json json = base;
  for (size_t p = 0; p < space.parameters.size(); ++p)
    *Find(&json, space.parameters[p].path) = Json::parse(values[p]);
  const std::string text = json.dump();
  *training = TrainingOptionsFromJson(text, what);
  *detector = DetectorOptionsFromJson(text, what);
}

// Integers as integers; other numbers to 4 significant digits, so drawn
// values read well in reports and options files.
std::string NumberJson(double value, bool integer) {
  if (integer) return std::to_string(static_cast<long long>(std::llround(value)));
  char text[32];
  std::snprintf(text, sizeof(text), "%.4g", value);
  return Json(std::stod(text)).dump();
}

// The values a grid tries for one parameter.
std::vector<std::string> GridValues(const TuneParameter& parameter) {
  if (!parameter.is_range) return parameter.values;
  std::vector<std::string> values;
  for (int k = 0; k < parameter.steps; ++k) {
    const double t = parameter.steps == 1 ? 0.5 : static_cast<double>(k) / (parameter.steps - 1);
    const double value = parameter.log ? parameter.min * std::pow(parameter.max / parameter.min, t)
                                       : parameter.min + t * (parameter.max - parameter.min);
    const std::string text = NumberJson(value, parameter.integer);
    if (std::find(values.begin(), values.end(), text) == values.end()) values.push_back(text);
  }
  return values;
}

std::string RandomValue(const TuneParameter& parameter, Rng* rng) {
  if (!parameter.is_range) {
    return parameter.values[rng->UniformInt(0, static_cast<int64_t>(parameter.values.size()) - 1)];
  }
  if (parameter.integer && !parameter.log) {
    return std::to_string(
        rng->UniformInt(static_cast<int64_t>(parameter.min), static_cast<int64_t>(parameter.max)));
  }
  const double t = rng->Uniform01();
  const double value = parameter.log ? parameter.min * std::pow(parameter.max / parameter.min, t)
                                     : parameter.min + t * (parameter.max - parameter.min);
  return NumberJson(value, parameter.integer);
}

std::string Describe(const TuneSpace& space, const std::vector<std::string>& values) {
  std::string text;
  for (size_t p = 0; p < space.parameters.size(); ++p) {
    const std::string& path = space.parameters[p].path;
    text += (p ? ", " : "") + path.substr(path.rfind('.') + 1) + "=" + values[p];
  }
  return text;
}

// Every metric name an evaluation run can have: those of a made-up frame with
// an object of every class, seen and unseen, each found.
std::set<std::string> MetricNames() {
  FrameOutcome frame;
  frame.total_ms = 1;
  double x = 0;
  for (FurnitureClass c : EvaluationOptions{}.classes) {
    const std::string name = ClassName(c);
    for (bool seen : {true, false}) {
      x += 1;
      frame.truth.push_back({{x, 0, 0}, c, name, 1.0, 1.0, seen});
      frame.detections.push_back({{x, 0, 0}, c, name, 1.0, 1});
    }
  }
  frame.detections.push_back(
      {{-5, 0, 0}, FurnitureClass::kChair, "chair", 0.5, 1});  // a false positive
  std::set<std::string> names;
  for (const auto& [name, value] : EvaluateFrames({frame}, EvaluationOptions{}).metrics)
    names.insert(name);
  return names;
}

}  // namespace

TuneSpace ParseTuneSpace(const std::string& text, const std::string& what) {
  nlohmann::ordered_json json = ParseUserJson(text, what);
  Require(json.is_object() && !json.empty(),
          what +
              ": the search space must be a JSON object of option paths, e.g. "
              "{\"detector.cell_m\": [0.02, 0.03]}");
  Json known = CombinedJson(TrainingOptions{}, DetectorOptions{});
  TuneSpace space;
  for (const auto& [path, spec] : json.items()) {
    const Json* leaf = Find(&known, path);
    Require(leaf != nullptr && !leaf->is_object(),
            what + ": unknown parameter '" + path +
                "' (paths are options-file keys such as trainer.region_growing.delta_m or "
                "detector.relative_threshold)");
    Require(
        path != "detector.seed" && path != "trainer.vocabulary.seed" && path != "trainer.scan.seed",
        what + ": '" + path + "' is a seed, not a parameter to tune");
    TuneParameter parameter;
    parameter.path = path;
    if (spec.is_array()) {
      Require(!spec.empty(), what + ": '" + path + "' has an empty list of values");
      for (const auto& value : spec) parameter.values.push_back(value.dump());
    } else if (spec.is_object()) {
      for (const auto& [key, value] : spec.items()) {
        Require(key == "min" || key == "max" || key == "steps" || key == "log",
                what + ": '" + path + "' range has an unknown key '" + key +
                    "' (min, max, steps, log)");
      }
      Require(spec.contains("min") && spec.contains("max") && spec["min"].is_number() &&
                  spec["max"].is_number(),
              what + ": '" + path + "' range needs numbers min and max");
      parameter.is_range = true;
      parameter.min = spec["min"].get<double>();
      parameter.max = spec["max"].get<double>();
      parameter.integer = spec["min"].is_number_integer() && spec["max"].is_number_integer();
      Require(parameter.min <= parameter.max,
              what + ": '" + path + "' range is empty (min " + spec["min"].dump() + " > max " +
                  spec["max"].dump() + ")");
      if (spec.contains("steps")) {
        Require(spec["steps"].is_number_integer() && spec["steps"].get<int>() >= 1 &&
                    spec["steps"].get<int>() <= 1000,
                what + ": '" + path + "' steps must be an integer in 1..1000");
        parameter.steps = spec["steps"].get<int>();
      }
      if (spec.contains("log")) {
        Require(spec["log"].is_boolean(), what + ": '" + path + "' log must be true or false");
        parameter.log = spec["log"].get<bool>();
        Require(!parameter.log || parameter.min > 0,
                what + ": '" + path + "' log range needs min > 0");
      }
    } else {
      throw InputError(what + ": '" + path +
                       "' must be a list of values or a range {\"min\": a, \"max\": b}");
    }
    space.parameters.push_back(std::move(parameter));
  }
  return space;
}

namespace {

// Every value the search may use, alone on the base, must pass Check().
void CheckEveryValue(const Json& base,
                     const TuneSpace& space,
                     const std::vector<std::string>& base_values) {
  for (size_t p = 0; p < space.parameters.size(); ++p) {
    const TuneParameter& parameter = space.parameters[p];
    std::vector<std::string> candidates = GridValues(parameter);
    if (parameter.is_range) {
      candidates.push_back(NumberJson(parameter.min, parameter.integer));
      candidates.push_back(NumberJson(parameter.max, parameter.integer));
    }
    for (const std::string& candidate : candidates) {
      std::vector<std::string> values = base_values;
      values[p] = candidate;
      TrainingOptions training;
      DetectorOptions detector;
      BuildOptions(base,
                   space,
                   values,
                   "tune space " + parameter.path + " = " + candidate,
                   &training,
                   &detector);
    }
  }
}

// The grid's points (every combination of every parameter's values); more
// points than trials: a seeded sample, so every parameter varies.
std::vector<std::vector<std::string>> GridPoints(const TuneSpace& space, int count, Rng* rng) {
  std::vector<std::vector<std::string>> axes;
  double points = 1;
  for (const TuneParameter& parameter : space.parameters) {
    axes.push_back(GridValues(parameter));
    points *= axes.back().size();
  }
  Require(points <= 1e6,
          "the grid has " + std::to_string(static_cast<long long>(points)) +
              " points (at most 1000000); use fewer steps or --strategy random");
  std::vector<std::vector<std::string>> grid = {{}};
  for (const auto& axis : axes) {
    std::vector<std::vector<std::string>> longer;
    for (const auto& prefix : grid) {
      for (const std::string& value : axis) {
        longer.push_back(prefix);
        longer.back().push_back(value);
      }
    }
    grid = std::move(longer);
  }
  if (grid.size() + 1 > static_cast<size_t>(count))
    std::shuffle(grid.begin(), grid.end(), rng->engine());
  return grid;
}

}  // namespace

std::vector<TuneTrial> MakeTrials(const TuneSpace& space,
                                  TuneStrategy strategy,
                                  int count,
                                  uint64_t seed,
                                  const TrainingOptions& base_training,
                                  const DetectorOptions& base_detector) {
  Require(count >= 1 && count <= 10000, "trials " + std::to_string(count) + " must be in 1..10000");
  Json base = CombinedJson(base_training, base_detector);
  TuneTrial first;
  first.training = base_training;
  first.detector = base_detector;
  for (const TuneParameter& parameter : space.parameters) {
    const Json* value = Find(&base, parameter.path);
    Require(value != nullptr, "unknown parameter '" + parameter.path + "'");
    first.values.push_back(value->dump());
  }
  CheckEveryValue(base, space, first.values);
  std::vector<TuneTrial> trials = {first};
  std::set<std::vector<std::string>> seen = {first.values};
  auto add = [&](const std::vector<std::string>& values) {
    if (!seen.insert(values).second) return;
    TuneTrial trial;
    trial.index = static_cast<int>(trials.size());
    trial.values = values;
    BuildOptions(base,
                 space,
                 values,
                 "tune trial " + std::to_string(trial.index) + " (" + Describe(space, values) + ")",
                 &trial.training,
                 &trial.detector);
    trials.push_back(std::move(trial));
  };
  Rng rng(DeriveSeed(seed, 0x7475'6e65));  // "tune"
  if (strategy == TuneStrategy::kGrid) {
    for (const auto& values : GridPoints(space, count, &rng)) {
      if (static_cast<int>(trials.size()) >= count) break;
      add(values);
    }
  } else {
    for (int attempt = 0; attempt < 100 * count && static_cast<int>(trials.size()) < count;
         ++attempt) {
      std::vector<std::string> values;
      for (const TuneParameter& parameter : space.parameters)
        values.push_back(RandomValue(parameter, &rng));
      add(values);
    }
  }
  return trials;
}

void TuneOptions::Check() const {
  Require(!db_path.empty(), "tune needs a dataset (--db)");
  Require(!space_path.empty(), "tune needs a search space (--space)");
  Require(!work_dir.empty(), "tune needs a work directory for trained models (--work-dir)");
  Require(!out_dir.empty(), "tune needs an output directory for its report (--out)");
  ParseSplit(split);
  Require(TryParseEnum<Split>(test_split) || test_split.empty() || test_split == "none",
          "test split '" + test_split + "' must be train, val, test, all or none");
  Require(trials >= 1 && trials <= 10000,
          "trials " + std::to_string(trials) + " must be in 1..10000");
  Require(max_frames >= 0, "max frames must be >= 0");
  Require(max_ms >= 0, "--max-ms must be >= 0");
  Require(seeds >= 1 && seeds <= 20, "seeds " + std::to_string(seeds) + " must be in 1..20");
  Require(!objective.empty(), "the objective must name a metric, e.g. mAP@10cm");
  Require(trial_shards == 0 || (trial_shard >= 0 && trial_shard < trial_shards),
          "trial shard " + std::to_string(trial_shard) + "/" + std::to_string(trial_shards) +
              ": i/N needs 0 <= i < N");
  Require(trial_shards == 0 || !results_dir.empty(),
          "a shard of the trials needs a results folder (--results-dir)");
}

namespace {

// One search: its trials, the runs an earlier tune of the same search left
// in the dataset, the model cache, and the evaluation of a trial on a split.
class Tuning {
 public:
  Tuning(const Catalog& catalog, const TuneOptions& options)
      : catalog_(catalog),
        options_(options),
        space_text_(ReadFileBytes(options.space_path)),
        space_(ParseTuneSpace(space_text_, options.space_path)) {
    LoadBase();
    base_trainer_json_ = TrainingOptionsJson(base_training_);
    if (const std::set<std::string> names = MetricNames(); !names.count(options.objective)) {
      throw InputError("objective '" + options.objective +
                       "' is not a metric of evaluation runs (e.g. mAP@10cm, mAP@5cm, "
                       "AP/chair@10cm, cad_identified; 'workbench history' lists them all)");
    }
    objective_ = MetricId::Parse(options.objective);
    trials_ = MakeTrials(
        space_, options.strategy, options.trials, options.seed, base_training_, base_detector_);
    CheckBaseModel();
    DatasetDb check(options.db_path, DatasetDb::Mode::kReadOnly);  // before anything trains
    summary_.tune_id = TuneId();
    FindEarlierRuns();
  }

  TuneSummary Run() {
    if (options_.trial_shards > 0) return RunTrialShard();
    if (!options_.results_dir.empty()) CheckResultsFiles();
    std::vector<TuneReportTrial> scored;
    for (const TuneTrial& trial : trials_) scored.push_back(Score(trial));
    summary_.trials = static_cast<int>(trials_.size());
    Rank(&scored);
    const TuneTrial& best = trials_[scored.front().index];
    summary_.best_index = best.index;
    summary_.best_run = scored.front().run_id;
    for (const TuneReportTrial& row : scored) {
      if (row.index == 0) summary_.base_validation = row.metrics;
      if (row.index == best.index) summary_.best_validation = row.metrics;
    }
    if (TestSplitWanted()) {
      summary_.base_test = Evaluate(trials_[0], options_.test_split, "tune-test").second;
      summary_.best_test = best.index == 0
                               ? summary_.base_test
                               : Evaluate(best, options_.test_split, "tune-test").second;
    }
    std::filesystem::create_directories(options_.out_dir);
    summary_.best_options_path = options_.out_dir + "/best_options.json";
    WriteFileAtomically(summary_.best_options_path, OptionsFileJson(best.training, best.detector));
    summary_.report_path = options_.out_dir + "/index.html";
    WriteTuneReport(ReportInput(scored), options_.out_dir);
    return summary_;
  }

 private:
  // A task of `tune --shards`: its trials on the validation split, each
  // detector seed's frames into a shard file of the results folder.
  TuneSummary RunTrialShard() {
    for (const TuneTrial& trial : trials_) {
      if (trial.index % options_.trial_shards != options_.trial_shard) continue;
      for (int seed = 0; seed < options_.seeds; ++seed) {
        const std::string path = ResultsFile(trial, seed);
        // Done by an earlier tune, or by an earlier attempt of this task
        // (a file that does not read as a shard file is evaluated again).
        if (EarlierRun(trial, options_.split, seed) != 0 || ReadableShard(path)) continue;
        EvaluateCommandOptions evaluate = EvaluateOptionsFor(trial, options_.split, "tune", seed);
        evaluate.shard_count = 1;
        evaluate.shard_out = path;
        EvaluateModel(ModelFor(trial.training), options_.db_path, evaluate);
      }
      ++summary_.trials;
      std::printf("tune: trial %d of %d evaluated into %s\n",
                  trial.index,
                  static_cast<int>(trials_.size()),
                  options_.results_dir.c_str());
      std::fflush(stdout);
    }
    return summary_;
  }

  static bool ReadableShard(const std::string& path) {
    if (!std::filesystem::exists(path)) return false;
    try {
      ParseShardFile(path);
      return true;
    } catch (const InputError& error) {
      std::fprintf(stderr, "tune: %s: evaluated again\n", error.what());
      return false;
    }
  }

  // The final job of `tune --shards`: every task's file is there, reads and
  // belongs to its trial before any trial is stored (one bad file would
  // otherwise leave the first trials stored and the rest refused).
  void CheckResultsFiles() {
    for (const TuneTrial& trial : trials_) {
      for (int seed = 0; seed < options_.seeds; ++seed) {
        if (EarlierRun(trial, options_.split, seed) != 0) continue;
        const std::string path = ResultsFile(trial, seed);
        Require(std::filesystem::exists(path),
                path + ": missing: trial " + std::to_string(trial.index) + " (detector seed " +
                    std::to_string(seed) + ") was not evaluated; rerun 'tune --shards' to " +
                    "resubmit its task");
        EvaluateCommandOptions evaluate = EvaluateOptionsFor(trial, options_.split, "tune", seed);
        evaluate.check_only = true;
        MergeEvaluation(ModelFor(trial.training), options_.db_path, evaluate, {path});
      }
    }
  }

  std::string ResultsFile(const TuneTrial& trial, int seed) const {
    return options_.results_dir + "/trial-" + std::to_string(trial.index) + "-seed-" +
           std::to_string(seed) + ".json";
  }

  void LoadBase() {
    if (!options_.base_options_path.empty()) {
      const std::string text = ReadFileBytes(options_.base_options_path);
      if (ParseUserJson(text, options_.base_options_path).contains("trainer"))
        base_training_ = TrainingOptionsFromJson(text, options_.base_options_path);
      base_detector_ = DetectorOptionsFromJson(text, options_.base_options_path);
    }
    if (options_.base_detector) base_detector_ = *options_.base_detector;
  }

  void CheckBaseModel() const {
    if (options_.base_model_path.empty()) return;
    const TrainedModel model = LoadTrainedModel(options_.base_model_path);
    Require(TrainingOptionsJson({model.options, base_training_.scan}) == base_trainer_json_,
            options_.base_model_path +
                ": was trained with other trainer options than the base; leave out --model or "
                "pass the options file it was trained with");
  }

  // What identifies the search for resuming (not the objective or the
  // latency bound: they only rank).
  std::string TuneId() const {
    return ShortHash(
        Json{{"space", ParseUserJson(space_text_, options_.space_path)},
             {"strategy", options_.strategy == TuneStrategy::kGrid ? "grid" : "random"},
             {"trials", options_.trials},
             {"seed", options_.seed},
             {"split", options_.split},
             {"max_frames", options_.max_frames},
             {"base", CombinedJson(base_training_, base_detector_)},
             {"catalog", options_.catalog_spec}}
            .dump());
  }

  void FindEarlierRuns() {
    DatasetDb dataset(options_.db_path, DatasetDb::Mode::kReadOnly);
    for (const RunRecord& run : dataset.Runs()) {
      if (run.kind != "tune" && run.kind != "tune-test") continue;
      const nlohmann::json json = nlohmann::json::parse(run.options_json, nullptr, false);
      if (!json.is_object() || !json.contains("tune") ||
          json["tune"].value("id", "") != summary_.tune_id)
        continue;
      earlier_[{json["tune"]["trial"].get<int>(),
                std::string(EnumName(run.split)),
                json["tune"].value("seed", 0)}] = {run.id, json["tune"]["parameters"].dump()};
    }
  }

  bool TestSplitWanted() const {
    return !options_.test_split.empty() && options_.test_split != "none";
  }

  nlohmann::json ParametersOf(const TuneTrial& trial) const {
    nlohmann::json parameters = nlohmann::json::object();
    for (size_t p = 0; p < space_.parameters.size(); ++p)
      parameters[space_.parameters[p].path] = nlohmann::json::parse(trial.values[p]);
    return parameters;
  }

  // The run of a trial on a split with its seed-th detector seed that an
  // earlier tune stored with the same parameter values, or 0.
  int64_t EarlierRun(const TuneTrial& trial, const std::string& split, int seed) const {
    const auto it = earlier_.find({trial.index, split, seed});
    if (it == earlier_.end() || it->second.second != ParametersOf(trial).dump()) return 0;
    return it->second.first;
  }

  bool AllDoneBefore(const TuneTrial& trial, const std::string& split) const {
    for (int seed = 0; seed < options_.seeds; ++seed) {
      if (EarlierRun(trial, split, seed) == 0) return false;
    }
    return true;
  }

  // The model for the trial's trainer options: the base model, or one from
  // the cache, trained when missing. The cache is locked while a model is
  // made, so tasks of one array job (or two tunes) train each model once.
  std::string ModelFor(const TrainingOptions& training) {
    const std::string json = TrainingOptionsJson(training);
    if (json == base_trainer_json_ && !options_.base_model_path.empty())
      return options_.base_model_path;
    std::filesystem::create_directories(options_.work_dir + "/models");
    std::filesystem::create_directories(options_.work_dir + "/locks");
    const std::string hash = ShortHash(json + "\n" + options_.catalog_spec);
    const std::string path = options_.work_dir + "/models/" + hash + ".fcm";
    if (std::filesystem::exists(path)) return path;
    const FileLock lock(options_.work_dir + "/locks/" + hash + ".lock", "the model cache");
    if (!std::filesystem::exists(path)) {
      std::printf("tune: training a model for %s\n", path.c_str());
      std::fflush(stdout);
      TrainFromCatalog(catalog_, training.scan, training.trainer, path);
      ++summary_.models_trained;
    }
    return path;
  }

  // The trial's metrics on a split: the mean over its runs, one per detector
  // seed (RANSAC makes single runs noisy). Returns the first run's id.
  std::pair<int64_t, std::map<std::string, double>> Evaluate(const TuneTrial& trial,
                                                             const std::string& split,
                                                             const char* kind) {
    int64_t first_run = 0;
    std::map<std::string, std::pair<double, int>> sums;  // name -> (sum, runs)
    for (int seed = 0; seed < options_.seeds; ++seed) {
      const auto [run_id, metrics] = EvaluateWithSeed(trial, split, kind, seed);
      if (seed == 0) first_run = run_id;
      for (const auto& [name, value] : metrics) {
        sums[name].first += value;
        ++sums[name].second;
      }
    }
    std::map<std::string, double> mean;
    for (const auto& [name, sum] : sums) {
      if (sum.second == options_.seeds) mean[name] = sum.first / sum.second;
    }
    return {first_run, mean};
  }

  std::pair<int64_t, std::map<std::string, double>> EvaluateWithSeed(const TuneTrial& trial,
                                                                     const std::string& split,
                                                                     const char* kind,
                                                                     int seed) {
    if (const int64_t run_id = EarlierRun(trial, split, seed)) {
      DatasetDb dataset(options_.db_path, DatasetDb::Mode::kReadOnly);
      return {run_id, dataset.RunMetrics(run_id)};
    }
    const EvaluateCommandOptions evaluate = EvaluateOptionsFor(trial, split, kind, seed);
    const std::string model = ModelFor(trial.training);
    if (!options_.results_dir.empty() && split == options_.split) {  // a task evaluated it
      const std::string path = ResultsFile(trial, seed);
      Require(std::filesystem::exists(path),
              path + ": missing: trial " + std::to_string(trial.index) + " (detector seed " +
                  std::to_string(seed) + ") was not evaluated; rerun 'tune --shards' to " +
                  "resubmit its task");
      const EvaluateSummary result = MergeEvaluation(model, options_.db_path, evaluate, {path});
      return {result.run_id, result.result.metrics};
    }
    const EvaluateSummary result = EvaluateModel(model, options_.db_path, evaluate);
    return {result.run_id, result.result.metrics};
  }

  // How a trial is evaluated on a split with its seed-th detector seed.
  EvaluateCommandOptions EvaluateOptionsFor(const TuneTrial& trial,
                                            const std::string& split,
                                            const char* kind,
                                            int seed) const {
    EvaluateCommandOptions evaluate;
    evaluate.split = ParseSplit(split);
    evaluate.max_frames = options_.max_frames;
    evaluate.kind = kind;
    evaluate.label = "tune " + summary_.tune_id.substr(0, 8) + " trial " +
                     std::to_string(trial.index) +
                     (trial.index == 0 ? " (base)" : ": " + Describe(space_, trial.values));
    evaluate.detector = trial.detector;
    evaluate.detector.seed = DeriveSeed(trial.detector.seed, static_cast<uint64_t>(seed));
    if (seed == 0) evaluate.detector.seed = trial.detector.seed;  // the options' own seed first
    evaluate.extra_options_json =
        Json{{"tune",
              {{"id", summary_.tune_id},
               {"trial", trial.index},
               {"seed", seed},
               {"parameters", ParametersOf(trial)}}},
             {"trainer", Json::parse(TrainingOptionsJson(trial.training))}}
            .dump();
    return evaluate;
  }

  // Evaluates the trial on the validation split (or finds it done) and says
  // so on a line.
  TuneReportTrial Score(const TuneTrial& trial) {
    const bool resumed = AllDoneBefore(trial, options_.split);
    const auto [run_id, metrics] = Evaluate(trial, options_.split, "tune");
    TuneReportTrial row;
    row.index = trial.index;
    row.run_id = run_id;
    row.values = trial.values;
    row.metrics = metrics;
    row.within_latency = options_.max_ms <= 0 || MetricOrNan(metrics, kLatency) <= options_.max_ms;
    row.retrained = TrainingOptionsJson(trial.training) != base_trainer_json_;
    summary_.trials_resumed += resumed;
    std::printf("tune: trial %d (%d of %d)%s: %s = %.3f, p50 %.1f ms (run %lld) %s\n",
                trial.index,
                trial.index + 1,
                static_cast<int>(trials_.size()),
                resumed ? " (done before)" : "",
                options_.objective.c_str(),
                MetricOrNan(metrics, objective_),
                MetricOrNan(metrics, kLatency),
                static_cast<long long>(run_id),
                trial.index == 0 ? "base" : Describe(space_, trial.values).c_str());
    std::fflush(stdout);
    return row;
  }

  // Within the latency bound first, then the objective, then the earlier
  // trial (the base first): timings are not a tie-break, so a rerun, or the
  // same search as an array job whose tasks share nodes, picks the same best.
  void Rank(std::vector<TuneReportTrial>* scored) const {
    const MetricId& objective = objective_;
    std::stable_sort(
        scored->begin(), scored->end(), [&](const TuneReportTrial& a, const TuneReportTrial& b) {
          if (a.within_latency != b.within_latency) return a.within_latency;
          const double oa = MetricOrNan(a.metrics, objective),
                       ob = MetricOrNan(b.metrics, objective);
          if (oa != ob) return std::isnan(ob) || oa > ob;
          return a.index < b.index;
        });
  }

  TuneReportInput ReportInput(const std::vector<TuneReportTrial>& scored) const {
    TuneReportInput report;
    report.title = "tune " + summary_.tune_id.substr(0, 8) + ": " +
                   std::to_string(summary_.trials) + " trials on " + options_.db_path + ", split " +
                   options_.split;
    report.objective = options_.objective;
    report.max_ms = options_.max_ms;
    for (const TuneParameter& parameter : space_.parameters)
      report.parameters.push_back(parameter.path);
    report.trials = scored;
    report.best_options_file = "best_options.json";
    report.validation_split = options_.split;
    report.test_split = TestSplitWanted() ? options_.test_split : "";
    report.base_validation = summary_.base_validation;
    report.best_validation = summary_.best_validation;
    report.base_test = summary_.base_test;
    report.best_test = summary_.best_test;
    report.best_index = summary_.best_index;
    report.notes = {
        std::string("Search: ") + (options_.strategy == TuneStrategy::kGrid ? "grid" : "random") +
            ", seed " + std::to_string(options_.seed) + ", " + std::to_string(options_.seeds) +
            " detector seed(s) per trial (metrics are their mean), space " + options_.space_path +
            ", catalog " + options_.catalog_spec + "; " + std::to_string(summary_.models_trained) +
            " models trained this time (cache: " + options_.work_dir + "/models).",
        "Use the best options: workbench train --options best_options.json --out best.fcm; "
        "workbench evaluate --model best.fcm --options best_options.json --db ... (detect takes "
        "--options too).",
        "Every trial is a run in the dataset (kind tune; the test re-evaluation: tune-test), so "
        "workbench history, report and regress work on them."};
    return report;
  }

  const Catalog& catalog_;
  const TuneOptions& options_;
  const std::string space_text_;  // the space file, read once
  const TuneSpace space_;
  TrainingOptions base_training_;
  std::string base_trainer_json_;  // TrainingOptionsJson(base_training_)
  DetectorOptions base_detector_;
  MetricId objective_ = MetricId::MeanAp(0.10);
  const MetricId kLatency = MetricId::Plain(PlainMetric::kLatencyP50);
  std::vector<TuneTrial> trials_;
  // (trial, split, seed) -> run id and the parameter values it ran with.
  std::map<std::tuple<int, std::string, int>, std::pair<int64_t, std::string>> earlier_;
  TuneSummary summary_;
};

}  // namespace

TuneSummary RunTuning(const Catalog& catalog, const TuneOptions& options) {
  options.Check();
  return Tuning(catalog, options).Run();
}

void CheckTuning(const Catalog& catalog, const TuneOptions& options) {
  options.Check();
  const Tuning checked(catalog, options);
}

}  // namespace furn
