#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "core/error.h"
#include "core/file_util.h"
#include "core/progress.h"
#include "db/dataset_db.h"
#include "reports/run_report.h"
#include "workbench/cli_common.h"
#include "workbench/commands.h"
#include "workbench/crossval.h"
#include "workbench/evaluate_command.h"
#include "workbench/train_command.h"

namespace furn {
namespace {

void PrintHeadline(const EvaluateSummary& summary) {
  const std::map<std::string, double>& m = summary.result.metrics;
  auto get = [&](const std::string& name) { return MetricOrNan(m, name); };
  std::printf("run %lld: %d frames in %.1f s, %g objects to find\n",
              static_cast<long long>(summary.run_id),
              summary.frames,
              summary.seconds,
              get("objects"));
  if (summary.frames_without_points > 0) {
    std::printf("  %d frames had no point in range: counted with no detections\n",
                summary.frames_without_points);
  }
  if (summary.frames_without_floor > 0) {
    std::printf("  %d frames had no floor found: counted with no detections\n",
                summary.frames_without_floor);
  }
  std::printf("  mAP@5cm %.3f  mAP@10cm %.3f  mAP@20cm %.3f  (seen %.3f, unseen %.3f)\n",
              get("mAP@5cm"),
              get("mAP@10cm"),
              get("mAP@20cm"),
              get("mAP_seen@10cm"),
              get("mAP_unseen@10cm"));
  for (const char* c : {"chair", "armchair", "table", "sideboard"}) {
    std::printf("  %-9s AP@10cm %.3f   paper protocol best F1 %.3f\n",
                c,
                get(std::string("AP/") + c + "@10cm"),
                get(std::string("paper/") + c + "/best_f1"));
  }
  std::printf("  pose error: xy %.3f m, yaw %.1f deg; CAD model identified %.3f\n",
              get("xy_error_mean_m"),
              get("yaw_error_mean_deg"),
              get("cad_identified"));
  // Where the objects were lost, biggest first (the report has it per class).
  std::vector<std::pair<double, std::string>> losses;
  for (const char* stage : kFunnelStages) {
    const double n = get(std::string("funnel/all/") + stage);
    if (n > 0) losses.emplace_back(-n, stage);
  }
  std::sort(losses.begin(), losses.end());
  std::printf("  objects by stage reached:");
  for (size_t k = 0; k < losses.size(); ++k)
    std::printf("%s %s %.0f", k ? "," : "", losses[k].second.c_str(), -losses[k].first);
  std::printf(
      "\n  false positives: duplicate %.0f, mislocated %.0f, wrong class %.0f, background %.0f\n",
      get("false_positives/duplicate"),
      get("false_positives/mislocated"),
      get("false_positives/wrong_class"),
      get("false_positives/background"));
  std::printf("  latency per frame: p50 %.1f ms, p90 %.1f ms, p99 %.1f ms\n",
              get("latency_p50_ms"),
              get("latency_p90_ms"),
              get("latency_p99_ms"));
}

// A value of a table column `width` wide; "-" for a metric a fold lacks (no
// object of that class in its frames).
std::string Cell(double value, int width) {
  char text[32];
  if (std::isnan(value)) {
    std::snprintf(text, sizeof(text), "%*s", width, "-");
  } else {
    std::snprintf(text, sizeof(text), "%*.3f", width, value);
  }
  return text;
}

void PrintCrossval(const CrossvalSummary& summary) {
  const char* classes[] = {"chair", "armchair", "table", "sideboard"};
  std::printf("leave-models-out (protocol E): %d folds (fold seed %llu), run %lld, %.0f s\n",
              summary.folds,
              static_cast<unsigned long long>(summary.fold_seed),
              static_cast<long long>(summary.run_id),
              summary.seconds);
  std::printf("%-6s %6s %7s %13s", "fold", "frames", "objects", "mAP@10cm");
  for (const char* c : classes) std::printf(" %13s", c);
  std::printf("\n");
  for (const CrossvalFold& fold : summary.per_fold) {
    const auto& m = fold.evaluation.result.metrics;
    std::printf("%-6d %6d %7.0f %s",
                fold.fold,
                fold.evaluation.frames,
                MetricOrNan(m, "objects"),
                Cell(MetricOrNan(m, "mAP@10cm"), 13).c_str());
    for (const char* c : classes)
      std::printf(" %s", Cell(MetricOrNan(m, std::string("AP/") + c + "@10cm"), 13).c_str());
    std::printf("\n");
  }
  auto both = [&](const std::string& name) {
    std::printf(" %s±%s",
                Cell(MetricOrNan(summary.mean, name), 7).c_str(),
                Cell(MetricOrNan(summary.spread, name), 5).c_str());
  };
  std::printf("%-6s %6.0f %7.0f",
              "mean",
              MetricOrNan(summary.mean, "frames"),
              MetricOrNan(summary.mean, "objects"));
  both("mAP@10cm");
  for (const char* c : classes) both(std::string("AP/") + c + "@10cm");
  std::printf("\n  mAP@5cm %.3f  mAP@20cm %.3f  xy error %.3f m  latency p50 %.1f ms\n",
              MetricOrNan(summary.mean, "mAP@5cm"),
              MetricOrNan(summary.mean, "mAP@20cm"),
              MetricOrNan(summary.mean, "xy_error_mean_m"),
              MetricOrNan(summary.mean, "latency_p50_ms"));
  if (!summary.gates.empty()) {
    std::printf("  without the scorer (fixed gates): mAP@10cm %.3f;",
                MetricOrNan(summary.gates, "mAP@10cm"));
    for (const char* c : classes)
      std::printf(" %s %.3f", c, MetricOrNan(summary.gates, std::string("AP/") + c + "@10cm"));
    std::printf(
        "\n  scorer: nested per fold; %d hypotheses in all; calibration error %.3f; "
        "all-folds scorer written to %s\n",
        summary.scorer_samples,
        MetricOrNan(summary.mean, "calibration_error"),
        summary.scorer_path.empty() ? "(none: too few hypotheses)" : summary.scorer_path.c_str());
  }
}

}  // namespace

// Protocol D: the three vocabularies over several seeds, each trained on the
// catalog and evaluated as its own run; mean and spread of the headline metrics.
int CompareVocabularies(const CatalogFlags& catalog_flags,
                        const std::string& db_path,
                        const std::string& work_dir,
                        int seeds,
                        EvaluateCommandOptions options) {
  Require(seeds >= 1 && seeds <= 20, "--seeds must be in 1..20");
  Require(!work_dir.empty(), "--compare-vocab needs --work-dir for the trained models");
  const Catalog catalog = OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags));
  struct Variant {
    const char* name;
    VocabularyKind kind;
    RimInit init;
  };
  const Variant variants[] = {{"kmeans", VocabularyKind::kKMeans, RimInit::kKMeans},
                              {"rim-kmeans-init", VocabularyKind::kRim, RimInit::kKMeans},
                              {"rim-pca-init", VocabularyKind::kRim, RimInit::kPcaSplit}};
  std::printf("%-16s %5s %10s %10s %10s %12s\n",
              "vocabulary",
              "seed",
              "mAP@10cm",
              "mAP@5cm",
              "chair F1",
              "run");
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
      auto get = [&](const char* name) { return MetricOrNan(m, name); };
      map10.push_back(get("mAP@10cm"));
      std::printf("%-16s %5d %10.3f %10.3f %10.3f %12lld\n",
                  variant.name,
                  seed,
                  get("mAP@10cm"),
                  get("mAP@5cm"),
                  get("paper/chair/best_f1"),
                  static_cast<long long>(summary.run_id));
    }
    double mean = 0, square = 0;
    for (double v : map10) mean += v / map10.size();
    for (double v : map10) square += (v - mean) * (v - mean) / map10.size();
    std::printf("%-16s  mean mAP@10cm %.3f +- %.3f over %d seeds\n",
                variant.name,
                mean,
                std::sqrt(square),
                seeds);
  }
  return 0;
}

int RunEvaluate(int argc, char** argv) {
  CLI::App app{"Run detection over a dataset split and store the metrics as a run",
               "workbench evaluate"};
  std::string model_path, db_path;
  EvaluateCommandOptions options;
  app.add_option("--model", model_path, "Model file (.fcm)");
  app.add_option("--db", db_path, "Dataset database")->required();
  app.add_option("--split", options.split, "train, val, test or all")->capture_default_str();
  app.add_option("--max-frames", options.max_frames, "Evaluate at most N frames (0: all)")
      ->capture_default_str();
  app.add_option("--label", options.label, "Free text stored with the run");
  app.add_option("--threshold", options.detector.relative_threshold, "Relative vote threshold t")
      ->capture_default_str();
  app.add_option(
         "--min-verification", options.detector.min_verification, "Minimum visibility score")
      ->capture_default_str();
  app.add_option("--min-score", options.detector.min_score, "Minimum detection score")
      ->capture_default_str();
  app.add_option("--seed", options.detector.seed, "Seed of the RANSAC draws")
      ->capture_default_str();
  app.add_option("--max-hypotheses",
                 options.detector.max_hypotheses_per_class,
                 "Strongest maxima fitted per class")
      ->capture_default_str();
  app.add_option("--top-models", options.detector.top_models, "CAD models fitted per maximum")
      ->capture_default_str();
  app.add_option("--fit-iterations", options.detector.fit.iterations, "RANSAC draws per fit")
      ->capture_default_str();
  std::string options_file;
  app.add_option("--options",
                 options_file,
                 "Detector options as JSON (a run's options or a tuned file); the flags above "
                 "apply on top when given");
  bool compare_vocab = false;
  int seeds = 3;
  std::string work_dir;
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  app.add_flag("--compare-vocab",
               compare_vocab,
               "Protocol D: train k-means, RIM (k-means init) and RIM (PCA init) on --catalog "
               "for each seed and evaluate each (instead of --model)");
  app.add_option("--seeds", seeds, "Seeds per vocabulary (with --compare-vocab)")
      ->capture_default_str();
  app.add_option("--work-dir", work_dir, "Where --compare-vocab writes its models");
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);  // --quiet: no progress bar
  if (!options_file.empty()) {
    DetectorOptions merged = DetectorOptionsFromJson(ReadFileBytes(options_file), options_file);
    const DetectorOptions& flags = options.detector;  // explicitly given flags win
    if (app.count("--threshold")) merged.relative_threshold = flags.relative_threshold;
    if (app.count("--min-verification")) merged.min_verification = flags.min_verification;
    if (app.count("--min-score")) merged.min_score = flags.min_score;
    if (app.count("--seed")) merged.seed = flags.seed;
    if (app.count("--max-hypotheses"))
      merged.max_hypotheses_per_class = flags.max_hypotheses_per_class;
    if (app.count("--top-models")) merged.top_models = flags.top_models;
    if (app.count("--fit-iterations")) merged.fit.iterations = flags.fit.iterations;
    options.detector = merged;
  }
  options.detector.Check();
  if (compare_vocab) return CompareVocabularies(catalog_flags, db_path, work_dir, seeds, options);
  Require(!model_path.empty(), "--model is required (or --compare-vocab)");
  const EvaluateSummary summary = EvaluateModel(model_path, db_path, options);
  PrintHeadline(summary);
  return 0;
}

int RunCrossval(int argc, char** argv) {
  CLI::App app{
      "Protocol E, leave-models-out: per fold, train without its models and evaluate on its "
      "rooms; mean and spread stored as a run",
      "workbench crossval"};
  std::string db_path, options_file;
  CrossvalOptions options;
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  app.add_option("--db",
                 db_path,
                 "Dataset database made by 'generate --model-folds K' (runs are stored in it)")
      ->required();
  app.add_option("--work-dir", options.work_dir, "Where the fold models go (reused when unchanged)")
      ->required();
  app.add_option("--split", options.evaluate.split, "train, val, test or all")
      ->capture_default_str();
  app.add_option("--max-frames", options.evaluate.max_frames, "At most N frames per fold (0: all)")
      ->capture_default_str();
  app.add_option("--label", options.evaluate.label, "Free text stored with the run");
  app.add_option("--options",
                 options_file,
                 "Options file: its \"trainer\" trains the fold models, its \"detector\" "
                 "detects");
  app.add_option("--seed", options.evaluate.detector.seed, "Seed of the RANSAC draws")
      ->capture_default_str();
  bool no_scorer = false;
  app.add_flag("--no-scorer",
               no_scorer,
               "Fixed verification gates only: no learned hypothesis scorer per fold");
  app.add_option("--scorer-trees", options.scorer_options.trees, "Trees of the scorer's forest")
      ->capture_default_str();
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);
  options.quiet = catalog_flags.quiet;
  options.scorer = !no_scorer;
  options.scorer_options.Check();
  if (!options_file.empty()) {
    const std::string text = ReadFileBytes(options_file);
    const uint64_t seed = options.evaluate.detector.seed;
    if (nlohmann::json::parse(text, nullptr, false).contains("trainer"))
      options.training = TrainingOptionsFromJson(text, options_file);
    options.evaluate.detector = DetectorOptionsFromJson(text, options_file);
    if (app.count("--seed")) options.evaluate.detector.seed = seed;
  }
  options.evaluate.detector.Check();
  // The catalog the dataset was generated from, unless --catalog says otherwise.
  if (app.count("--catalog") == 0) {
    const std::optional<std::string> generation =
        DatasetDb(db_path, DatasetDb::Mode::kReadOnly).GenerationOptions();
    if (generation)
      catalog_flags.spec = nlohmann::json::parse(*generation).value("catalog", "default");
  }
  const Catalog catalog = OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags));
  const CrossvalSummary summary = RunLeaveModelsOut(catalog, db_path, options);

  PrintCrossval(summary);
  return 0;
}

int RunReport(int argc, char** argv) {
  CLI::App app{"Write the HTML/PNG report of an evaluation run", "workbench report"};
  std::string db_path, out;
  int64_t run_id = 0;
  app.add_option("--db", db_path, "Dataset database holding the run")->required();
  app.add_option("--run", run_id, "Run id (0: the latest)")->capture_default_str();
  app.add_option("--out", out, "Report directory (index.html and PNGs)")->required();
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  // A failure leaves no half-written report behind.
  WriteDirectoryAtomically(
      out, [&](const std::string& dir) { WriteReportForRun(db_path, run_id, dir); });
  std::printf("wrote %s/index.html\n", out.c_str());
  return 0;
}

int RunHistory(int argc, char** argv) {
  CLI::App app{"Every metric across runs and commits, as plots and a table", "workbench history"};
  std::vector<std::string> db_paths;
  std::string out;
  app.add_option("--db",
                 db_paths,
                 "Dataset database holding the runs; repeat it to show datasets side by side "
                 "(synthetic and real)")
      ->required();
  app.add_option("--out", out, "Directory for history.html and its plots")->required();
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  std::vector<HistoryDataset> datasets;
  size_t runs = 0;
  for (const std::string& db_path : db_paths) {
    DatasetDb dataset(db_path, DatasetDb::Mode::kReadOnly);
    HistoryDataset history;
    history.name = std::filesystem::path(db_path).filename().string();
    history.runs = dataset.Runs();
    Require(!history.runs.empty(), db_path + ": has no runs (run 'workbench evaluate' first)");
    for (const RunRecord& run : history.runs) history.metrics.push_back(dataset.RunMetrics(run.id));
    runs += history.runs.size();
    datasets.push_back(std::move(history));
  }
  WriteDirectoryAtomically(out, [&](const std::string& dir) { WriteHistoryReport(datasets, dir); });
  std::printf(
      "wrote %s/history.html: %zu runs of %zu datasets\n", out.c_str(), runs, datasets.size());
  return 0;
}

int RunRegress(int argc, char** argv) {
  CLI::App app{"Compare a run's metrics with a baseline; exit 1 when any got worse",
               "workbench regress"};
  std::string db_path, baseline, write_baseline;
  int64_t run_id = 0;
  double tolerance = 0.02, latency_tolerance = 0;
  app.add_option("--db", db_path, "Dataset database holding the run")->required();
  app.add_option("--run", run_id, "Run id (0: the latest)")->capture_default_str();
  app.add_option("--baseline", baseline, "Run id, or a baseline JSON file");
  app.add_option("--tolerance", tolerance, "Allowed absolute worsening of a metric")
      ->capture_default_str();
  app.add_option("--latency-tolerance",
                 latency_tolerance,
                 "Allowed relative latency growth (0: latency not compared)")
      ->capture_default_str();
  app.add_option("--write-baseline", write_baseline, "Write the run's metrics as a baseline file");
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  Require(tolerance >= 0, "--tolerance must be >= 0");
  Require(!baseline.empty() || !write_baseline.empty(),
          "give --baseline to compare, or --write-baseline to record one");
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadOnly);
  const std::vector<RunRecord> runs = dataset.Runs();
  Require(!runs.empty(), db_path + ": has no runs (run 'workbench evaluate' first)");
  if (run_id == 0) run_id = runs.back().id;
  const std::map<std::string, double> metrics = dataset.RunMetrics(run_id);
  Require(!metrics.empty(), db_path + ": no run with id " + std::to_string(run_id));
  if (!write_baseline.empty()) {
    nlohmann::ordered_json json{{"run", run_id},
                                {"db", db_path},
                                {"metrics", metrics},
                                {"tolerances", nlohmann::json::object()}};
    WriteFileAtomically(write_baseline, json.dump(2) + "\n");
    std::printf("wrote %s: %zu metrics of run %lld\n",
                write_baseline.c_str(),
                metrics.size(),
                static_cast<long long>(run_id));
    if (baseline.empty()) return 0;
  }
  std::map<std::string, double> base, overrides;
  std::string base_name;
  if (!baseline.empty() && baseline.find_first_not_of("0123456789") == std::string::npos) {
    base = dataset.RunMetrics(std::stoll(baseline));
    Require(!base.empty(), db_path + ": no baseline run with id " + baseline);
    base_name = "run " + baseline;
  } else {
    nlohmann::json json;
    try {
      json = nlohmann::json::parse(ReadFileBytes(baseline));
      base = json.at("metrics").get<std::map<std::string, double>>();
      if (json.contains("tolerances"))
        overrides = json["tolerances"].get<std::map<std::string, double>>();
    } catch (const nlohmann::json::exception& error) {
      throw InputError(baseline +
                       ": not a baseline file ({\"metrics\": {name: value}}): " + error.what());
    }
    base_name = baseline;
  }
  const std::vector<Regression> regressions =
      FindRegressions(metrics, base, tolerance, overrides, latency_tolerance);
  if (regressions.empty()) {
    std::printf("run %lld: no metric worse than %s beyond tolerance (%zu compared)\n",
                static_cast<long long>(run_id),
                base_name.c_str(),
                base.size());
    return 0;
  }
  for (const Regression& r : regressions) {
    if (std::isnan(r.value)) {
      std::printf("REGRESSION %s: missing from run %lld (baseline %.4f)\n",
                  r.metric.c_str(),
                  static_cast<long long>(run_id),
                  r.baseline);
    } else {
      std::printf("REGRESSION %s: %.4f, baseline %.4f (allowed %.4f worse)\n",
                  r.metric.c_str(),
                  r.value,
                  r.baseline,
                  r.tolerance);
    }
  }
  std::printf("run %lld: %zu metrics worse than %s\n",
              static_cast<long long>(run_id),
              regressions.size(),
              base_name.c_str());
  return 1;
}

}  // namespace furn
