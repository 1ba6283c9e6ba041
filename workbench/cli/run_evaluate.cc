#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <tuple>
#include <vector>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "reports/run_report.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/cluster_flags.h"
#include "workbench/cli/commands.h"
#include "workbench/cli/detector_flags.h"
#include "workbench/pipelines/compare_vocab.h"
#include "workbench/pipelines/crossval.h"
#include "workbench/pipelines/evaluate.h"
#include "workbench/pipelines/evaluation_report.h"
#include "workbench/pipelines/generate.h"  // ParseShard
#include "workbench/pipelines/regression.h"
#include "workbench/pipelines/train.h"

namespace furn {
namespace {

// The classes a printout shows: the paper's four, then any other class the
// metrics have an AP for.
std::vector<FurnitureClass> PrintedClasses(const std::map<std::string, double>& metrics) {
  std::vector<FurnitureClass> classes(kPaperClasses.begin(), kPaperClasses.end());
  for (FurnitureClass c : kAllClasses) {
    if (std::find(classes.begin(), classes.end(), c) == classes.end() &&
        metrics.count(MetricId::ClassAp(c, 0.10).Name()))
      classes.push_back(c);
  }
  return classes;
}

// The detections at the operating point, over every class.
void PrintOperatingPoint(const std::map<std::string, double>& m, const char* indent) {
  const double op = OperatingMatchOf(m);
  std::printf(
      "%sat the operating point (matched at %.0f cm): precision %.3f, recall %.3f, F1 %.3f, "
      "%.2f false detections per frame\n",
      indent,
      op * 100,
      MetricOrNan(m, MetricId::Operating(std::nullopt, OperatingMeasure::kPrecision, op)),
      MetricOrNan(m, MetricId::Operating(std::nullopt, OperatingMeasure::kRecall, op)),
      MetricOrNan(m, MetricId::Operating(std::nullopt, OperatingMeasure::kF1, op)),
      MetricOrNan(m, MetricId::Operating(std::nullopt, OperatingMeasure::kFalsePerFrame, op)));
}

// Where the objects were lost, biggest first (the report has it per class).
void PrintLosses(const std::map<std::string, double>& m) {
  std::vector<std::pair<double, std::string>> losses;
  for (FunnelStage stage : EnumValues<FunnelStage>()) {
    const double n = MetricOrNan(m, MetricId::Funnel(std::nullopt, stage));
    if (n > 0) losses.emplace_back(-n, EnumName(stage));
  }
  std::sort(losses.begin(), losses.end());
  std::printf("  objects by stage reached:");
  for (size_t k = 0; k < losses.size(); ++k)
    std::printf("%s %s %.0f", k ? "," : "", losses[k].second.c_str(), -losses[k].first);
  std::printf(
      "\n  false positives: duplicate %.0f, mislocated %.0f, wrong class %.0f, background %.0f\n",
      MetricOrNan(m, MetricId::FalsePositives(FalsePositiveKind::kDuplicate)),
      MetricOrNan(m, MetricId::FalsePositives(FalsePositiveKind::kMislocated)),
      MetricOrNan(m, MetricId::FalsePositives(FalsePositiveKind::kWrongClass)),
      MetricOrNan(m, MetricId::FalsePositives(FalsePositiveKind::kBackground)));
}

// centre/<class>/median_m per class on one line; the reach reads "≥".
void PrintCentreErrors(const std::map<std::string, double>& m,
                       const std::vector<FurnitureClass>& classes) {
  std::string line;
  for (FurnitureClass c : classes) {
    const double median = MetricOrNan(m, MetricId::CentreErrorMedian(c));
    if (std::isnan(median)) continue;
    char text[64];
    std::snprintf(text,
                  sizeof(text),
                  "%s %s%.1f cm",
                  ClassName(c),
                  median >= kCentreErrorReachM ? ">= " : "",
                  median * 100);
    line += (line.empty() ? "" : ", ") + std::string(text);
  }
  if (line.empty()) return;
  std::printf("  centre error median (objects seen >= %.0f %%, nearest detection): %s\n",
              kCentreErrorVisibility * 100,
              line.c_str());
}

// The field's box metrics (SUN RGB-D / ScanNet): AP at 3-D IoU 0.25 and 0.5
// per class and their mean, and the bird's-eye view's; nothing for a run
// without 3-D boxes (a set labelled without heights).
void PrintIouAp(const std::map<std::string, double>& m,
                const std::vector<FurnitureClass>& classes) {
  if (!m.count(MetricId::IouAp(std::nullopt, 0.25, false).Name())) return;
  std::printf(
      "  box IoU (all-point AP, greedy by score as mmdetection3d): mAP3D@0.25 %.3f  "
      "mAP3D@0.50 %.3f  mAPBEV@0.25 %.3f  mAPBEV@0.50 %.3f\n",
      MetricOrNan(m, MetricId::IouAp(std::nullopt, 0.25, false)),
      MetricOrNan(m, MetricId::IouAp(std::nullopt, 0.5, false)),
      MetricOrNan(m, MetricId::IouAp(std::nullopt, 0.25, true)),
      MetricOrNan(m, MetricId::IouAp(std::nullopt, 0.5, true)));
  for (FurnitureClass c : classes) {
    std::printf("  %-9s AP3D@0.25 %.3f  AP3D@0.50 %.3f  APBEV@0.25 %.3f  APBEV@0.50 %.3f\n",
                ClassName(c),
                MetricOrNan(m, MetricId::IouAp(c, 0.25, false)),
                MetricOrNan(m, MetricId::IouAp(c, 0.5, false)),
                MetricOrNan(m, MetricId::IouAp(c, 0.25, true)),
                MetricOrNan(m, MetricId::IouAp(c, 0.5, true)));
  }
}

void PrintHeadline(const EvaluateSummary& summary) {
  const std::map<std::string, double>& m = summary.result.metrics;
  auto get = [&](PlainMetric metric) { return MetricOrNan(m, MetricId::Plain(metric)); };
  std::printf("run %lld: %d frames in %.1f s, %g objects to find\n",
              static_cast<long long>(summary.run_id),
              summary.frames,
              summary.seconds,
              get(PlainMetric::kObjects));
  if (summary.frames_without_points > 0) {
    std::printf("  %d frames had no point in range: counted with no detections\n",
                summary.frames_without_points);
  }
  if (summary.frames_without_floor > 0) {
    std::printf("  %d frames had no floor found: counted with no detections\n",
                summary.frames_without_floor);
  }
  std::printf("  mAP@5cm %.3f  mAP@10cm %.3f  mAP@20cm %.3f  (seen %.3f, unseen %.3f)\n",
              MetricOrNan(m, MetricId::MeanAp(0.05)),
              MetricOrNan(m, MetricId::MeanAp(0.10)),
              MetricOrNan(m, MetricId::MeanAp(0.20)),
              get(PlainMetric::kMeanApSeen),
              get(PlainMetric::kMeanApUnseen));
  const double op = OperatingMatchOf(m);
  for (FurnitureClass c : PrintedClasses(m)) {
    std::printf(
        "  %-9s %3.0f objects  AP@10cm %.3f  at the operating point precision %.2f recall %.2f",
        ClassName(c),
        ClassObjectCount(m, c),
        MetricOrNan(m, MetricId::ClassAp(c, 0.10)),
        MetricOrNan(m, MetricId::Operating(c, OperatingMeasure::kPrecision, op)),
        MetricOrNan(m, MetricId::Operating(c, OperatingMeasure::kRecall, op)));
    // Protocol A sweeps the detector's own maxima: not in another program's run.
    if (m.count(MetricId::PaperBestF1(c).Name()))
      std::printf("   paper protocol best F1 %.3f", MetricOrNan(m, MetricId::PaperBestF1(c)));
    std::printf("\n");
  }
  PrintIouAp(m, PrintedClasses(m));
  PrintOperatingPoint(m, "  ");
  PrintCentreErrors(m, PrintedClasses(m));
  std::printf(
      "  pose error: xy %.3f m, yaw %.1f deg (median %.1f); footprint size error median %.3f; "
      "CAD model identified %.3f\n",
      get(PlainMetric::kXyErrorMean),
      get(PlainMetric::kYawErrorMean),
      get(PlainMetric::kYawErrorMedian),
      get(PlainMetric::kSizeErrorMedian),
      get(PlainMetric::kCadIdentified));
  PrintLosses(m);
  if (m.count(MetricId::Plain(PlainMetric::kLatencyP50).Name())) {
    std::printf("  latency per frame: p50 %.1f ms, p90 %.1f ms, p99 %.1f ms\n",
                get(PlainMetric::kLatencyP50),
                get(PlainMetric::kLatencyP90),
                get(PlainMetric::kLatencyP99));
  } else {
    std::printf("  latency: not given for every frame (\"time_ms\")\n");
  }
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

// The per-fold table and its mean +- spread row.
void PrintFolds(const CrossvalSummary& summary, const std::vector<FurnitureClass>& classes) {
  const MetricId map10 = MetricId::MeanAp(0.10);
  std::printf("%-6s %6s %7s %13s", "fold", "frames", "objects", "mAP@10cm");
  for (FurnitureClass c : classes)
    std::printf(" %13s", (std::string(ClassName(c)) + " (n)").c_str());
  std::printf("\n");
  for (const CrossvalFold& fold : summary.per_fold) {
    const auto& m = fold.evaluation.result.metrics;
    std::printf("%-6d %6d %7.0f %s",
                fold.fold,
                fold.evaluation.frames,
                MetricOrNan(m, MetricId::Plain(PlainMetric::kObjects)),
                Cell(MetricOrNan(m, map10), 13).c_str());
    for (FurnitureClass c : classes) {  // AP with its objects: "0.805 (95)"
      const double ap = MetricOrNan(m, MetricId::ClassAp(c, 0.10));
      char text[40];
      std::snprintf(text, sizeof(text), "%.3f (%.0f)", ap, ClassObjectCount(m, c));
      std::printf(" %13s", std::isnan(ap) ? "-" : text);
    }
    std::printf("\n");
  }
  auto both = [&](const MetricId& id) {
    std::printf(" %s±%s",
                Cell(MetricOrNan(summary.mean, id), 7).c_str(),
                Cell(MetricOrNan(summary.spread, id), 5).c_str());
  };
  std::printf("%-6s %6.0f %7.0f",
              "mean",
              MetricOrNan(summary.mean, MetricId::Plain(PlainMetric::kFrames)),
              MetricOrNan(summary.mean, MetricId::Plain(PlainMetric::kObjects)));
  both(map10);
  for (FurnitureClass c : classes) both(MetricId::ClassAp(c, 0.10));
}

// The learned folds' training budget beside the default model's (issue 70):
// a fold network trained on fewer rooms or epochs is not the model a user
// gets, and its figure says so in the same line.
void PrintVoteNetBudget(const CrossvalSummary& summary, const VoteNetTrainingOptions& folds) {
  const VoteNetTrainingOptions budget;
  constexpr double kDefaultBudgetMap = kDefaultBudgetProtocolEMap;
  const double map = MetricOrNan(summary.mean, MetricId::MeanAp(0.10));
  if (folds.rooms == budget.rooms && folds.epochs == budget.epochs) {
    std::printf(
        "  fold networks at the default model's budget (%d rooms x %d epochs): mAP@10cm "
        "%.3f (the default budget measured %.3f over nine fold networks)\n",
        budget.rooms,
        budget.epochs,
        map,
        kDefaultBudgetMap);
    return;
  }
  std::printf(
      "  fold networks at %d rooms x %d epochs, not the default model's %d x %d: mAP@10cm "
      "%.3f here, %.3f at the default budget (nine fold networks; %+.3f)\n",
      folds.rooms,
      folds.epochs,
      budget.rooms,
      budget.epochs,
      map,
      kDefaultBudgetMap,
      map - kDefaultBudgetMap);
}

void PrintCrossval(const CrossvalSummary& summary) {
  const std::vector<FurnitureClass> classes = PrintedClasses(summary.mean);
  std::printf("leave-models-out (protocol E): %d folds (fold seed %llu), run %lld, %.0f s\n",
              summary.folds,
              static_cast<unsigned long long>(summary.fold_seed),
              static_cast<long long>(summary.run_id),
              summary.seconds);
  PrintFolds(summary, classes);
  std::printf("\n  mAP@5cm %.3f  mAP@20cm %.3f  xy error %.3f m  latency p50 %.1f ms\n",
              MetricOrNan(summary.mean, MetricId::MeanAp(0.05)),
              MetricOrNan(summary.mean, MetricId::MeanAp(0.20)),
              MetricOrNan(summary.mean, MetricId::Plain(PlainMetric::kXyErrorMean)),
              MetricOrNan(summary.mean, MetricId::Plain(PlainMetric::kLatencyP50)));
  PrintOperatingPoint(summary.mean, "  ");
  PrintCentreErrors(summary.mean, classes);
  if (summary.gates.empty()) return;
  std::printf("  without the scorer (fixed gates): mAP@10cm %.3f;",
              MetricOrNan(summary.gates, MetricId::MeanAp(0.10)));
  for (FurnitureClass c : classes)
    std::printf(" %s %.3f", ClassName(c), MetricOrNan(summary.gates, MetricId::ClassAp(c, 0.10)));
  std::printf(
      "\n  scorer: nested per fold; %d hypotheses in all; calibration error %.3f; "
      "all-folds scorer written to %s\n",
      summary.scorer_samples,
      MetricOrNan(summary.mean, MetricId::Plain(PlainMetric::kCalibrationError)),
      summary.scorer_path.empty() ? "(none: too few hypotheses)" : summary.scorer_path.c_str());
}

// Protocol D (--compare-vocab): a row per vocabulary and seed, then the means.
void CompareVocabulariesAndPrint(const Catalog& catalog,
                                 const std::string& db_path,
                                 const std::string& work_dir,
                                 int seeds,
                                 const EvaluateCommandOptions& options) {
  std::printf("%-16s %5s %10s %10s %10s %12s\n",
              "vocabulary",
              "seed",
              "mAP@10cm",
              "mAP@5cm",
              "chair F1",
              "run");
  CompareVocabularies(
      catalog,
      db_path,
      work_dir,
      seeds,
      options,
      [](const VocabularyRun& run) {
        std::printf("%-16s %5d %10.3f %10.3f %10.3f %12lld\n",
                    run.vocabulary.c_str(),
                    run.seed,
                    run.map10,
                    run.map5,
                    run.chair_best_f1,
                    static_cast<long long>(run.run_id));
      },
      [](const VocabularyMean& mean) {
        std::printf("%-16s  mean mAP@10cm %.3f +- %.3f over %d seeds\n",
                    mean.vocabulary.c_str(),
                    mean.map10_mean,
                    mean.map10_spread,
                    mean.seeds);
      });
}

// `evaluate` as an array job: task i evaluates shard i/N of the frames into
// the job folder; the final job is the same evaluate, which merges the N
// shard files into one run of the dataset.
ArrayJob EvaluateArrayJob(const ClusterFlags& cluster, int argc, char** argv) {
  ArrayJob job = NewArrayJob(cluster, "evaluate");
  SetTaskOutput(&job, "shard-", ".json");
  const std::set<std::string> drop = {"--shard", "--shard-out", "--merge-shards"};
  job.task_command = TaskCommandLine(
      argc,
      argv,
      drop,
      "--quiet --shard " + TaskShardArgument(job) + " --shard-out " + TaskOutputArgument(job));
  job.final_command = TaskCommandLine(argc, argv, drop, "--merge-shards" + AllTaskOutputs(job));
  return job;
}

// Evaluate in this process: a whole run, one shard of it, or the merge of
// the shards.
int EvaluateHere(const std::string& model_path,
                 const std::string& db_path,
                 const std::string& shard,
                 const std::vector<std::string>& merge,
                 EvaluateCommandOptions options) {
  if (!merge.empty()) {
    const EvaluateSummary summary = MergeEvaluation(model_path, db_path, options, merge);
    std::printf("merged %zu shards%s:\n",
                merge.size(),
                summary.already_stored ? " (stored before by an earlier attempt; not again)" : "");
    PrintHeadline(summary);
    return 0;
  }
  if (options.shard_count > 0) {
    const EvaluateSummary summary = EvaluateModel(model_path, db_path, options);
    std::printf("shard %s: %d frames in %.1f s, written to %s\n",
                shard.c_str(),
                summary.frames,
                summary.seconds,
                options.shard_out.c_str());
    return 0;
  }
  PrintHeadline(EvaluateModel(model_path, db_path, options));
  return 0;
}

// --min-in-view, shared by evaluate and crossval.
void AddMinInViewOption(CLI::App* app, EvaluationOptions* evaluation) {
  app->add_option("--min-in-view",
                  evaluation->min_in_view,
                  "Objects with less of their box inside the image (cut by its side) are "
                  "neither found nor missed (0: every object counts, as in every figure so far)")
      ->capture_default_str();
}

// --fuse-room-frames and --fuse-pose-noise, shared by evaluate and crossval.
void AddFusionOptions(CLI::App* app, FrameFusion* fusion) {
  app->add_flag("--fuse-room-frames",
                fusion->room_frames,
                "Detect each frame with the other frames of its room fused in (their known "
                "poses), seen from its own camera; its ground truth unchanged (protocol E is one "
                "frame: this measures what a posed sequence gives)");
  app->add_option_function<std::string>(
      "--fuse-pose-noise",
      [fusion](const std::string& text) { ParsePoseNoise(text, fusion); },
      "M,DEG[,planar]: with --fuse-room-frames, the other frames' poses with a random error "
      "of sigma M metres along and DEG degrees about each axis (odometry's; planar: along x "
      "and y and about z only); the same error every run");
  app->add_flag("--fuse-register",
                fusion->register_poses,
                "With --fuse-room-frames: refine the other frames' poses against the frame's "
                "points first (generalized ICP), after any --fuse-pose-noise");
  AddFusePlanarFlag(app, &fusion->planar);
}

// What detects: a model (--model, its detections optionally written out
// with --write-detections) or another program's file (--detections).
void AddDetectionSourceOptions(CLI::App* app,
                               std::string* model_path,
                               std::string* detections,
                               std::string* write_detections) {
  app->add_option("--model", *model_path, "Model file (.fcm)");
  app->add_option("--detections",
                  *detections,
                  "Score detections another program wrote for the dataset's frames instead of "
                  "running a model: a JSON-lines file or a directory of them (format "
                  "furnidet-detections 1, or detect's own output; docs/evaluation.md)");
  app->add_option("--write-detections",
                  *write_detections,
                  "Also write the run's detections (every candidate) to this file in the "
                  "furnidet-detections format, for other tools and for --detections");
}

// Protocol D instead of a model: --compare-vocab, --seeds, --work-dir.
void AddCompareVocabOptions(CLI::App* app, bool* compare_vocab, int* seeds, std::string* work_dir) {
  app->add_flag("--compare-vocab",
                *compare_vocab,
                "Protocol D: train k-means, RIM (k-means init) and RIM (PCA init) on --catalog "
                "for each seed and evaluate each (instead of --model)");
  app->add_option("--seeds", *seeds, "Seeds per vocabulary (with --compare-vocab)")
      ->capture_default_str();
  app->add_option("--work-dir", *work_dir, "Where --compare-vocab writes its models");
}

// What a run covers and how it is scored: frames, label, operating-point
// match distance and leave-models-out fold ("k/N" into `fold`).
void AddRunOptions(CLI::App* app, EvaluateCommandOptions* options, std::string* fold) {
  app->add_option("--max-frames", options->max_frames, "Evaluate at most N frames (0: all)")
      ->capture_default_str();
  app->add_option("--label", options->label, "Free text stored with the run");
  app->add_option("--op-match",
                  options->op_match_m,
                  "Operating-point metrics: a detection this near (m) a true object of its class "
                  "is true (0: the model's, 20 cm; real sets of visible-part centres: 0.5)")
      ->capture_default_str();
  app->add_option("--fold",
                  *fold,
                  "k/N: only the rooms of model fold k of N (a dataset generated with "
                  "--model-folds N; what crossval evaluates fold k's model on)");
}

}  // namespace

int RunEvaluate(int argc, char** argv) {
  CLI::App app{"Run detection over a dataset split and store the metrics as a run",
               "workbench evaluate"};
  std::string model_path, db_path, split = "test", detections;
  EvaluateCommandOptions options;
  AddDetectionSourceOptions(&app, &model_path, &detections, &options.write_detections);
  app.add_option("--db", db_path, "Dataset database")->required();
  app.add_option("--split", split, "train, val, test or all")->capture_default_str();
  AddMinInViewOption(&app, &options.evaluation);
  AddFusionOptions(&app, &options.fusion);
  std::string fold;
  AddRunOptions(&app, &options, &fold);
  DetectorFlags detector_flags(&app);
  bool compare_vocab = false;
  int seeds = 3;
  std::string work_dir;
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  AddCompareVocabOptions(&app, &compare_vocab, &seeds, &work_dir);
  std::string shard;
  std::vector<std::string> merge;
  app.add_option("--shard",
                 shard,
                 "i/N: evaluate only frames p of the split with p % N == i, into --shard-out "
                 "(what each task of 'evaluate --shards' does)");
  app.add_option("--shard-out", options.shard_out, "With --shard: the shard file to write");
  app.add_option("--merge-shards",
                 merge,
                 "Shard files 0..N-1 of this evaluation: store them as one run (the final job "
                 "of 'evaluate --shards')");
  ClusterFlags cluster;
  AddClusterFlags(&app, &cluster);
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);  // --quiet: no progress bar
  cluster.Check();
  options.fusion.Check();  // before an array job is submitted
  Require(shard.empty() == options.shard_out.empty(), "--shard i/N and --shard-out go together");
  Require(shard.empty() || merge.empty(), "--shard and --merge-shards do not go together");
  Require(!(compare_vocab && !detections.empty()),
          "--compare-vocab and --detections exclude each other");
  Require(!(compare_vocab && (cluster.Active() || !shard.empty() || !merge.empty())),
          "--compare-vocab runs in one process (no --shards, --shard or --merge-shards)");
  if (!shard.empty()) std::tie(options.shard_index, options.shard_count) = ParseShard(shard);
  if (!fold.empty()) {
    try {
      std::tie(options.fold, options.fold_count) = ParseShard(fold);
    } catch (const InputError&) {
      throw InputError("--fold '" + fold + "' must be k/N with 0 <= k < N, e.g. 1/3");
    }
  }
  options.split = ParseSplit(split, "--split");
  options.detector = detector_flags.Resolve();
  if (compare_vocab) {
    CompareVocabulariesAndPrint(OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags)),
                                db_path,
                                work_dir,
                                seeds,
                                options);
    return 0;
  }
  if (!detections.empty()) {
    Require(model_path.empty(), "--detections scores a file of detections: no --model");
    Require(!cluster.Active() && shard.empty() && merge.empty(),
            "--detections runs in one process (no --shards, --shard or --merge-shards)");
    Require(options.write_detections.empty(), "--write-detections needs --model, not --detections");
    PrintHeadline(EvaluateDetections(detections, db_path, options));
    return 0;
  }
  Require(!model_path.empty(), "--model is required (or --detections, or --compare-vocab)");
  if (cluster.Active()) {
    Require(shard.empty() && merge.empty(),
            "--shards N runs --shard and --merge-shards itself; give neither");
    // Checked here, before a job is submitted: the files every task needs.
    DatasetDb(db_path, DatasetDb::Mode::kReadOnly);
    Require(std::filesystem::is_regular_file(model_path), model_path + ": no such model file");
    return RunArrayJob(cluster, EvaluateArrayJob(cluster, argc, argv));
  }
  return EvaluateHere(model_path, db_path, shard, merge, options);
}

namespace {

// `crossval` as an array job: task k trains fold k's model into the work
// directory (--train-fold k); the final job is the same crossval, which finds
// every fold model there, evaluates the folds and stores the runs.
ArrayJob CrossvalArrayJob(const ClusterFlags& cluster,
                          const std::string& db_path,
                          int argc,
                          char** argv) {
  const int folds = ReadDatasetFolds(db_path).count;
  Require(cluster.shards == folds,
          "--shards " + std::to_string(cluster.shards) + ": " + db_path + " has " +
              std::to_string(folds) + " folds, one task each (--shards " + std::to_string(folds) +
              ")");
  ArrayJob job = NewArrayJob(cluster, "crossval");
  job.task_command = TaskCommandLine(argc, argv, {}, "--quiet --train-fold \"$TASK\"");
  job.final_command = TaskCommandLine(argc, argv, {}, "");
  return job;
}

}  // namespace

int RunCrossval(int argc, char** argv) {
  CLI::App app{
      "Protocol E, leave-models-out: per fold, train without its models and evaluate on its "
      "rooms; mean and spread stored as a run",
      "workbench crossval"};
  std::string db_path;
  CrossvalOptions options;
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  app.add_option("--db",
                 db_path,
                 "Dataset database made by 'generate --model-folds K' (runs are stored in it)")
      ->required();
  app.add_option("--work-dir", options.work_dir, "Where the fold models go (reused when unchanged)")
      ->required();
  std::string split = "all";
  app.add_option("--split", split, "train, val, test or all")->capture_default_str();
  AddMinInViewOption(&app, &options.evaluate.evaluation);
  AddFusionOptions(&app, &options.evaluate.fusion);
  app.add_option("--max-frames", options.evaluate.max_frames, "At most N frames per fold (0: all)")
      ->capture_default_str();
  app.add_option("--label", options.evaluate.label, "Free text stored with the run");
  // --options: its "trainer" trains the fold models, its "detector" detects;
  // --no-scorer: fixed verification gates only, no learned scorer per fold.
  DetectorFlags detector_flags(&app);
  app.add_option("--scorer-trees", options.scorer_options.trees, "Trees of the scorer's forest")
      ->capture_default_str();
  VoteNetFlags vote_net;
  AddVoteNetFlags(&app, &vote_net);
  app.add_option("--train-fold",
                 options.train_only_fold,
                 "Only train (or find) fold K's model into --work-dir, evaluate nothing (what "
                 "each task of 'crossval --shards' does)");
  ClusterFlags cluster;
  AddClusterFlags(&app, &cluster);
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);
  cluster.Check();
  options.evaluate.fusion.Check();  // before any fold is trained
  if (cluster.Active()) {
    Require(app.count("--train-fold") == 0, "--train-fold and --shards do not go together");
    return RunArrayJob(cluster, CrossvalArrayJob(cluster, db_path, argc, argv));
  }
  options.quiet = catalog_flags.quiet;
  if (const VoteNetTrainingOptions* v = vote_net.Resolve(catalog_flags.quiet))
    options.vote_net = *v;
  options.scorer = !detector_flags.no_scorer();
  options.scorer_options.Check();
  options.evaluate.split = ParseSplit(split, "--split");
  options.evaluate.detector = detector_flags.Resolve(/*apply_no_scorer=*/false);
  if (const std::string& file = detector_flags.options_file(); !file.empty()) {
    const std::string text = ReadFileBytes(file);
    if (nlohmann::json::parse(text, nullptr, false).contains("trainer"))
      options.training = TrainingOptionsFromJson(text, file);
  }
  // The catalog the dataset was generated from, unless --catalog says otherwise.
  if (app.count("--catalog") == 0) {
    const std::optional<std::string> generation =
        DatasetDb(db_path, DatasetDb::Mode::kReadOnly).GenerationOptions();
    if (generation)
      catalog_flags.spec = nlohmann::json::parse(*generation).value("catalog", "default");
  }
  const Catalog catalog = OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags));
  const CrossvalSummary summary = RunLeaveModelsOut(catalog, db_path, options);
  if (options.train_only_fold >= 0) {
    const CrossvalFold& fold = summary.per_fold.front();
    std::printf("fold %d of %d: %s %s\n",
                fold.fold,
                summary.folds,
                fold.model_reused ? "model present:" : "trained",
                fold.model_path.c_str());
    return 0;
  }
  PrintCrossval(summary);
  if (options.vote_net) PrintVoteNetBudget(summary, *options.vote_net);
  return 0;
}

int RunReport(int argc, char** argv) {
  CLI::App app{"Write the HTML/PNG report of an evaluation run", "workbench report"};
  std::string db_path, out;
  int64_t run_id = 0;
  app.add_option("--db", db_path, "Dataset database holding the run")->required();
  app.add_option("--run", run_id, "Run id (0: the latest)")->capture_default_str();
  app.add_option("--out", out, "Report directory (index.html and PNGs)")->required();
  bool quiet = false;
  app.add_flag("--quiet,-q", quiet, "Print nothing but errors");
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  // A failure leaves no half-written report behind.
  WriteDirectoryAtomically(
      out, [&](const std::string& dir) { WriteReportForRun(db_path, run_id, dir); });
  if (!quiet) std::printf("wrote %s/index.html\n", out.c_str());
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
  bool quiet = false;
  app.add_flag("--quiet,-q", quiet, "Print nothing but errors");
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
  if (!quiet)
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
    WriteBaselineFile(write_baseline, run_id, db_path, metrics);
    std::printf("wrote %s: %zu metrics of run %lld\n",
                write_baseline.c_str(),
                metrics.size(),
                static_cast<long long>(run_id));
    if (baseline.empty()) return 0;
  }
  const Baseline base = LoadBaseline(dataset, db_path, baseline);
  const std::vector<Regression> regressions =
      FindRegressions(metrics, base.metrics, tolerance, base.tolerances, latency_tolerance);
  if (regressions.empty()) {
    std::printf("run %lld: no metric worse than %s beyond tolerance (%zu compared)\n",
                static_cast<long long>(run_id),
                base.name.c_str(),
                base.metrics.size());
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
              base.name.c_str());
  return 1;
}

}  // namespace furn
