#include "workbench/pipelines/evaluation_report.h"

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/detector/detector.h"
#include "core/util/error.h"
#include "db/dataset_db.h"
#include "reports/detection_debug.h"
#include "reports/run_report.h"
#include "reports/run_results.h"
#include "reports/scene_view.h"
#include "workbench/formats/external_detections.h"
#include "workbench/formats/options_file.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/train_vote_net.h"  // the default budget

namespace furn {

namespace {

// A frame of another program's detections (those at the operating point) as
// the debug writer draws a result: its points above the floor in the world,
// in no segment, and the boxes (with no CAD model; their heights the
// class's, as the run's detections table keeps no size).
DetectionResult ResultOfExternalFrame(const LoadedScan& scan,
                                      const ExternalFrame& frame,
                                      const OperatingPoint& kept) {
  DetectionResult result;
  // The labels' frame, which the program's boxes are in.
  result.world_from_camera =
      scan.label_from_camera ? *scan.label_from_camera
                             : scan.input.world_from_camera.value_or(Eigen::Isometry3d::Identity());
  const Eigen::Isometry3f world_from_camera = result.world_from_camera.cast<float>();
  for (const Eigen::Vector3f& p : scan.input.points) {
    const Eigen::Vector3f world = world_from_camera * p;
    if (p.allFinite() && world.z() > 0.02f) result.debug.points.push_back(world);
  }
  result.debug.segment_of_point.assign(result.debug.points.size(), -1);
  for (const ScoredDetection& d : frame.detections) {
    if (!kept.Keeps(d.furniture_class, d.score)) continue;
    Detection detection;
    static_cast<FurnitureBox&>(detection) = d;
    detection.furniture_class = d.furniture_class;
    detection.model_name = d.model_id;
    detection.score = d.score;
    if (detection.width <= 0) {  // a box the program took from a model: its footprint
      detection.width = d.box3d.size.y();
      detection.depth = d.box3d.size.x();
    }
    result.detections.push_back(detection);
  }
  result.input_points = static_cast<int>(scan.input.points.size());
  return result;
}

// The frames with the most errors at 10 cm among the detections at the
// operating point (as evaluate counted them), detection rerun as detect runs
// it (deterministic: the same result) with the debug PNGs and a 3-D page
// each, linked to one another in gallery order.
std::vector<GalleryFrame> WriteGallery(const std::string& db_path,
                                       const RunRecord& run,
                                       const RunResults& results,
                                       const std::string& out_dir) {
  struct Errors {
    int64_t frame_id;
    int fp, fn;
  };
  std::vector<Errors> errors;
  for (const auto& [frame, counts] : results.frame_errors) {
    const Errors e{frame, counts.first, counts.second};
    if (e.fp + e.fn > 0) errors.push_back(e);
  }
  std::sort(errors.begin(), errors.end(), [](const Errors& a, const Errors& b) {
    return a.fp + a.fn != b.fp + b.fn ? a.fp + a.fn > b.fp + b.fn : a.frame_id < b.frame_id;
  });
  constexpr size_t kGallery = 6;
  errors.resize(std::min(kGallery, errors.size()));
  std::vector<GalleryFrame> gallery;
  if (errors.empty() || !std::filesystem::exists(run.model_path)) return gallery;
  // What detect outputs (the run itself swept every candidate for AP).
  DetectorOptions options = DetectorOptionsFromJson(run.options_json, db_path + " run options");
  options.all_candidates = !results.confusion_has_missed;  // older runs: as counted
  std::optional<Detector> detector;
  std::optional<ExternalDetections> external;
  const TrainedModel no_model;
  if (run.kind == "external") {  // another program's detections: read again, as scored
    external = ReadExternalDetections(run.model_path);
    if (external->content_hash != run.model_hash) return gallery;  // changed since
  } else {
    detector.emplace(LoadTrainedModel(run.model_path), options);
  }
  const OperatingPoint kept = options.EffectiveOperatingPoint(OperatingPoint{});
  auto detect = [&](const LoadedScan& scan, int64_t frame_id) {
    if (detector) return detector->Detect(scan.input, /*keep_debug=*/true);
    const auto found = external->frames.find(frame_id);
    return ResultOfExternalFrame(
        scan, found == external->frames.end() ? ExternalFrame{} : found->second, kept);
  };
  const TrainedModel& model = detector ? detector->model() : no_model;
  // A run of fused frames is shown fused, as it was evaluated.
  const FrameFusion fusion = FrameFusion::FromJson(
      nlohmann::json::parse(run.options_json).value("fusion", nlohmann::json()),
      db_path + " run " + std::to_string(run.id));
  WriteSceneLibrary((std::filesystem::path(out_dir) / "three").string());
  auto scene_of = [&](size_t k) {
    return k < errors.size() ? "../" + std::to_string(errors[k].frame_id) + "/scene.html"
                             : std::string();
  };
  for (size_t k = 0; k < errors.size(); ++k) {
    ScanSource source;
    source.db_path = db_path;
    source.frame_id = errors[k].frame_id;
    source.fusion = fusion;
    const LoadedScan scan = LoadScan(source);
    const DetectionResult result = detect(scan, errors[k].frame_id);
    GalleryFrame g{errors[k].frame_id, errors[k].fp, errors[k].fn, "", {}};
    g.dir = "frames/" + std::to_string(g.frame_id);
    const std::filesystem::path dir = std::filesystem::path(out_dir) / g.dir;
    SceneViewLinks links;
    links.title = "run " + std::to_string(run.id) + ", frame " + std::to_string(g.frame_id) + ": " +
                  std::to_string(g.false_positives) + " false, " +
                  std::to_string(g.false_negatives) + " missed";
    links.library = "../../three";
    links.previous = k > 0 ? scene_of(k - 1) : "";
    links.next = scene_of(k + 1);
    links.index = "../../index.html";
    // The gallery shows what the debug writer made (every class's vote map).
    g.pngs = WriteDetectionDebug(
        result, model, scan.camera, GroundTruthInDetectorFrame(scan, result), dir.string(), links);
    gallery.push_back(std::move(g));
  }
  return gallery;
}

}  // namespace

namespace {

void WriteReportForRunUnguarded(const std::string& db_path,
                                int64_t run_id,
                                const std::string& out_dir);

}  // namespace

void WriteReportForRun(const std::string& db_path, int64_t run_id, const std::string& out_dir) {
  try {
    WriteReportForRunUnguarded(db_path, run_id, out_dir);
  } catch (const nlohmann::json::exception& e) {  // a run row written by someone else
    std::string reason = e.what();                // "[json.exception.<kind>.<id>] <what>": the what
    if (reason.rfind("[json.exception.", 0) == 0 && reason.find("] ") != std::string::npos)
      reason = reason.substr(reason.find("] ") + 2);
    throw InputError(
        db_path + ": run " + (run_id == 0 ? std::string("(the latest)") : std::to_string(run_id)) +
        ": its stored options or results are not the JSON evaluate stores (" + reason + ")");
  }
}

namespace {

// A learned leave-models-out run's fold networks against the default
// model's training (issue 73: the main job's 150-room figure read as the
// default model's): the budget, and the default budget's own figure.
std::string BudgetNote(const nlohmann::json& options) {
  if (!options.contains("vote_net") || !options["vote_net"].is_object()) return "";
  const nlohmann::json& folds = options["vote_net"];
  const VoteNetTrainingOptions budget;
  const int rooms = folds.value("rooms", budget.rooms),
            epochs = folds.value("epochs", budget.epochs);
  char text[640];
  if (rooms == budget.rooms && epochs == budget.epochs) {
    std::snprintf(text,
                  sizeof(text),
                  "<p class=\"budget\"><b>Training budget</b>: each fold network was trained as "
                  "the default model is (%d rooms &times; %d epochs); nine such fold networks "
                  "measured mAP@10cm %.3f (docs/learned-voting.md).</p>\n",
                  rooms,
                  epochs,
                  kDefaultBudgetProtocolEMap);
  } else {
    std::snprintf(text,
                  sizeof(text),
                  "<p class=\"budget\"><b>Training budget</b>: each fold network here was trained "
                  "on %d rooms &times; %d epochs, <b>not</b> the default model's %d &times; %d: "
                  "these figures are of a shorter training than <code>train --catalog "
                  "default</code> gives. At the default budget, nine fold networks measured "
                  "mAP@10cm %.3f (docs/learned-voting.md).</p>\n",
                  rooms,
                  epochs,
                  budget.rooms,
                  budget.epochs,
                  kDefaultBudgetProtocolEMap);
  }
  return text;
}

void WriteReportForRunUnguarded(const std::string& db_path,
                                int64_t run_id,
                                const std::string& out_dir) {
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadOnly);
  const std::vector<RunRecord> runs = dataset.Runs();
  Require(!runs.empty(), db_path + ": has no runs (run 'workbench evaluate' first)");
  if (run_id == 0) run_id = runs.back().id;
  const RunRecord* run = nullptr;
  for (const RunRecord& r : runs) {
    if (r.id == run_id) run = &r;
  }
  Require(run != nullptr, db_path + ": no run with id " + std::to_string(run_id));
  RunReportInput input;
  input.run = *run;
  input.results = RunResults::Parse(run->results_json, db_path + ": run " + std::to_string(run_id));
  input.metrics = dataset.RunMetrics(run_id);
  if (run->kind == "crossval") {  // protocol E: a page of its own, each fold's report beside it
    const nlohmann::json fold_runs =
        nlohmann::json::parse(run->options_json).value("fold_runs", nlohmann::json::array());
    std::vector<std::string> fold_reports;
    for (size_t k = 0; k < fold_runs.size(); ++k) {
      fold_reports.push_back("fold-" + std::to_string(k));
      WriteReportForRun(db_path,
                        fold_runs[k].get<int64_t>(),
                        (std::filesystem::path(out_dir) / fold_reports.back()).string());
    }
    input.budget_note = BudgetNote(nlohmann::json::parse(run->options_json));
    WriteCrossvalReport(input, fold_reports, out_dir);
    return;
  }
  for (const RunFrameRecord& f : dataset.RunFrames(run_id)) input.frame_ms.push_back(f.total_ms);

  input.gallery = WriteGallery(db_path, *run, *input.results, out_dir);
  WriteRunReport(input, out_dir);
}

}  // namespace

}  // namespace furn
