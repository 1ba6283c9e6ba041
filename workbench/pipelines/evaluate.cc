#include "workbench/pipelines/evaluate.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "core/detector/detection_box.h"
#include "core/detector/voting_choice.h"
#include "core/geometry/mesh.h"
#include "core/geometry/pose_fit.h"
#include "core/geometry/render_compare.h"  // PinholeIntrinsics
#include "core/geometry/scene.h"
#include "core/geometry/view_share.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "renderers/camera.h"
#include "reports/detection_debug.h"
#include "reports/run_report.h"
#include "reports/run_results.h"
#include "reports/scene_view.h"
#include "scenes/model_folds.h"
#include "workbench/formats/external_detections.h"
#include "workbench/formats/json_text.h"
#include "workbench/formats/real_labels.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/evaluated_frame.h"
#include "workbench/pipelines/model_info.h"
#include "workbench/pipelines/run_program.h"
#include "workbench/pipelines/run_record.h"

namespace furn {

// The ground truth's box, as a detection's (Detection::in_view).
double ShareInView(const ObjectRecord& object, const FrameRecord& frame) {
  const CameraIntrinsics camera = IntrinsicsOf(frame);
  const ViewFrustum view = ViewFrustum::OfPinhole(
      PinholeIntrinsics{camera.fx, camera.fy, camera.cx, camera.cy}, camera.width, camera.height);
  const Eigen::Vector3d half(object.width / 2, object.depth / 2, 0);
  return ShareOfBoxInView(
      view,
      frame.world_from_camera.inverse() * PoseXYZYaw(object.x, object.y, object.z, object.yaw),
      -half,
      half + Eigen::Vector3d(0, 0, object.height));
}

int SymmetryOrder(const ModelShape& shape) {
  if (shape.points.empty()) return 1;
  const ModelFitter fitter(shape, FitOptions{});
  auto maps_onto_itself = [&](double angle) {
    return fitter.Covered(shape.points, PlanarPose{0, 0, angle}) >= 0.9 * shape.points.size();
  };
  if (maps_onto_itself(M_PI / 2)) return 4;
  if (maps_onto_itself(M_PI)) return 2;
  return 1;
}

namespace {

// The rooms of the split (and fold) to evaluate (without their images), the
// frames selected from them in order (a frame's position is its index here),
// and the hash of those frames' contents.
struct FrameSelection {
  struct Frame {
    int room = 0, frame = 0;  // indices into rooms and that room's frames
  };
  std::vector<RoomRecord> rooms;
  std::vector<Frame> frames;
  std::string dataset_hash;

  const RoomRecord& RoomAt(int position) const { return rooms[frames[position].room]; }
  const FrameRecord& FrameAt(int position) const {
    return RoomAt(position).frames[frames[position].frame];
  }
};

FrameSelection SelectFrames(DatasetDb& dataset,
                            const std::string& db_path,
                            const EvaluateCommandOptions& options) {
  FrameSelection selection;
  ContentHasher hash;
  for (int64_t id : dataset.RoomIds()) {
    RoomRecord room = dataset.ReadRoom(id, /*with_images=*/false);
    if (!InSplit(room.split, options.split)) continue;
    if (options.fold_count > 0 && FoldOfRoom(id, options.fold_count) != options.fold) continue;
    for (size_t k = 0; k < room.frames.size(); ++k) {
      if (options.max_frames > 0 && static_cast<int>(selection.frames.size()) >= options.max_frames)
        break;
      selection.frames.push_back({static_cast<int>(selection.rooms.size()), static_cast<int>(k)});
      hash.Update(room.frames[k].content_hash.data(), room.frames[k].content_hash.size());
    }
    selection.rooms.push_back(std::move(room));
  }
  Require(!selection.frames.empty(),
          db_path + ": no frames in split '" + EnumName(options.split) + "'" +
              (options.fold_count > 0 ? " of fold " + std::to_string(options.fold) : ""));
  selection.dataset_hash = hash.HexDigest();
  return selection;
}

// What the model knows that evaluation needs: each CAD model's rotational
// symmetry, and which CAD models it was trained on (seen, whatever the
// dataset's evaluation_only flags say: its rooms may come from other catalogs).
struct ModelFacts {
  std::vector<int> symmetry;
  std::set<std::string> trained;
};

// Without the symmetries (a merge of shards, whose detections carry them).
ModelFacts TrainedFactsOf(const TrainedModel& model) {
  ModelFacts facts;
  facts.trained.insert(model.model_names.begin(), model.model_names.end());
  return facts;
}

ModelFacts FactsOf(const TrainedModel& model) {
  ModelFacts facts = TrainedFactsOf(model);
  for (const ModelShape& shape : model.model_shapes) facts.symmetry.push_back(SymmetryOrder(shape));
  return facts;
}

// How much of the object a frame sees (0: not listed, out of view).
double VisibilityIn(const FrameRecord& frame, const ObjectRecord& object) {
  for (const FrameObjectRecord& seen : frame.objects) {
    if (seen.instance_id == object.instance_id) return seen.visibility;
  }
  return 0;
}

// The room's objects as the frame's ground truth; with fused frames, those
// another frame of the room sees are marked (TruthObject::seen_by_fused_frames).
std::vector<TruthObject> TruthOf(const RoomRecord& room,
                                 const FrameRecord& frame,
                                 const ModelFacts& facts,
                                 const FrameFusion& fusion) {
  std::vector<TruthObject> truth;
  const Eigen::Vector3d eye = frame.world_from_camera.translation();
  for (const ObjectRecord& object : room.objects) {
    const double visibility = VisibilityIn(frame, object);
    bool seen_by_fused_frames = false;
    for (const FrameRecord& other : room.frames) {
      seen_by_fused_frames |=
          fusion.room_frames && other.id != frame.id && VisibilityIn(other, object) > 0;
    }
    const Eigen::Vector3d reference(object.reference_x, object.reference_y, 0);
    truth.push_back({object.Footprint(),
                     object.furniture_class,
                     object.model_id,
                     visibility,
                     (reference - eye).norm(),
                     facts.trained.count(object.model_id) > 0,
                     // Only a target's share counts (clutter is never one).
                     object.furniture_class ? ShareInView(object, frame) : 1.0,
                     seen_by_fused_frames});
    if (object.height > 0) truth.back().box3d = WorldBoxOf(object.Footprint(), 0, object.height);
  }
  return truth;
}

// Hypotheses that passed the scorer's gates, labelled by the ground truth:
// positive when the fit lies within 10 cm of a true object of its class.
void AddScorerSamples(const DetectionResult& result,
                      const FrameRecord& frame,
                      const Eigen::Isometry3d& to_labels,
                      EvaluatedFrame* out) {
  for (const DetectionDebug::Hypothesis& h : result.debug.hypotheses) {
    if (!h.features) continue;
    ScorerSample sample;
    sample.features = h.features->Vector();
    sample.group = static_cast<uint64_t>(frame.id);
    const FurnitureBox fit = MovedBox({h.fit_x, h.fit_y}, to_labels);
    for (const TruthObject& t : out->outcome.truth) {
      sample.positive |=
          t.furniture_class == h.furniture_class && std::hypot(t.x - fit.x, t.y - fit.y) <= 0.10;
    }
    out->scorer_samples.push_back(sample);
  }
}

// A world box moved by a floor-aligned transform (a turn about z and a shift).
OrientedBox MovedOrientedBox(OrientedBox box, const Eigen::Isometry3d& moved) {
  box.centre = moved * box.centre;
  box.yaw += std::atan2(moved.linear()(1, 0), moved.linear()(0, 0));
  return box;
}

// The detector's output in the labels' frame, as the evaluation and the run
// see it.
void RecordDetections(const DetectionResult& result,
                      const FrameRecord& frame,
                      const Eigen::Isometry3d& to_labels,
                      const ModelFacts& facts,
                      const TrainedModel& model,
                      EvaluatedFrame* out) {
  for (const Detection& detected : result.detections) {
    Detection d = detected;
    d.box() = MovedBox(d.box(), to_labels);
    // A learned detection names no CAD model: its class's symmetry.
    const int symmetry =
        d.model_index >= 0 ? facts.symmetry[d.model_index] : BevYawSymmetry(d.furniture_class);
    out->outcome.detections.push_back(ScoredDetectionOf(d, symmetry));
    out->outcome.detections.back().box3d =
        MovedOrientedBox(DetectionBoxInWorld(detected, model), to_labels);
    out->detections.push_back({frame.id,
                               d.furniture_class,
                               d.model_name,
                               d.x,
                               d.y,
                               d.z,
                               d.yaw,
                               d.score,
                               d.vote_weight,
                               d.verification,
                               d.covered_fraction});
  }
  for (const DetectionDebug::Hypothesis& h : result.debug.hypotheses) {
    const FurnitureBox maximum = MovedBox({h.x, h.y}, to_labels);
    out->outcome.maxima.push_back(
        {h.furniture_class, maximum.x, maximum.y, h.relative_weight, h.outcome});
  }
  nlohmann::ordered_json timings = nlohmann::ordered_json::object();
  for (const StageTime& t : result.timings_ms.stages) {
    timings[EnumName(t.stage)] = t.ms;
    if (t.stage == DetectionStage::kTotal) {
      out->outcome.total_ms = t.ms;
    } else {
      out->outcome.stage_ms[t.stage] = t.ms;
    }
  }
  out->record = {frame.id,
                 out->outcome.total_ms,
                 timings.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)};
}

// Detection in one frame, its ground truth, and the records of the run.
// Real scans without a known floor: the detector finds it, and its
// detections move from its floor frame into the labels'.
EvaluatedFrame EvaluateFrame(const Detector& detector,
                             const RoomRecord& room,
                             const FrameRecord& frame,
                             bool estimate_pose,
                             const ModelFacts& facts,
                             const std::string& db_path,
                             const EvaluateCommandOptions& options) {
  const DetectionResult result =
      detector.Detect(RoomFrameInput(room, frame, options.fusion, estimate_pose, db_path));
  Eigen::Isometry3d to_labels = Eigen::Isometry3d::Identity();
  if (estimate_pose && result.status == DetectionStatus::kDetected)
    to_labels = frame.world_from_camera * result.world_from_camera.inverse();
  EvaluatedFrame out;
  out.status = result.status;
  out.outcome.frame_id = frame.id;
  out.outcome.truth = TruthOf(room, frame, facts, options.fusion);
  RecordDetections(result, frame, to_labels, facts, detector.model(), &out);
  if (options.collect_scorer_samples) AddScorerSamples(result, frame, to_labels, &out);
  return out;
}

// The run's stored options: every detector option and the evaluation's.
std::string StoredOptionsJson(const EvaluateCommandOptions& options,
                              const EvaluationOptions& evaluation) {
  nlohmann::ordered_json stored{
      {"detector", nlohmann::json::parse(DetectorOptionsJson(options.detector))},
      {"max_frames", options.max_frames},
      {"fold",
       options.fold_count > 0 ? nlohmann::json{options.fold, options.fold_count}
                              : nlohmann::json()},
      {"min_visibility", evaluation.min_visibility},
      {"min_in_view", evaluation.min_in_view},
      {"paper_window_m", evaluation.paper_window_m}};
  nlohmann::ordered_json point{{"match_m", evaluation.operating_point.match_m}};
  for (FurnitureClass c : kAllClasses) point[ClassName(c)] = evaluation.operating_point.MinScore(c);
  stored["operating_point"] = point;
  if (options.fusion.room_frames) stored["fusion"] = options.fusion.Json();
  if (!options.extra_options_json.empty()) {
    const nlohmann::ordered_json extra = nlohmann::ordered_json::parse(options.extra_options_json);
    for (const auto& [key, value] : extra.items()) stored[key] = value;
  }
  return stored.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace

namespace {

void CheckEvaluateOptions(const EvaluateCommandOptions& options) {
  Require(options.max_frames >= 0, "max frames must be >= 0");
  options.fusion.Check();
  Require(options.evaluation.min_in_view >= 0 && options.evaluation.min_in_view <= 1,
          "--min-in-view " + std::to_string(options.evaluation.min_in_view) + " must be in 0..1");
  Require(options.fold_count == 0 || (options.fold >= 0 && options.fold < options.fold_count),
          "fold " + std::to_string(options.fold) + " must be in 0.." +
              std::to_string(options.fold_count - 1));
  Require(options.shard_count == 0 ||
              (options.shard_index >= 0 && options.shard_index < options.shard_count),
          "shard " + std::to_string(options.shard_index) + "/" +
              std::to_string(options.shard_count) + ": i/N needs 0 <= i < N");
  Require(options.shard_count == 0 || !options.shard_out.empty(),
          "a shard of an evaluation needs the file to write it to");
  Require(
      options.op_match_m >= 0 && options.op_match_m <= 2,
      "--op-match " + std::to_string(options.op_match_m) + " must be in 0..2 m (0: the model's)");
  Require(options.shard_count == 0 || !options.collect_scorer_samples,
          "a shard of an evaluation does not collect scorer samples");
}

// A member joining the run's stored options (extra_options_json).
void AddStoredOption(EvaluateCommandOptions* options,
                     const std::string& key,
                     const nlohmann::ordered_json& value) {
  nlohmann::ordered_json extra = options->extra_options_json.empty()
                                     ? nlohmann::ordered_json::object()
                                     : nlohmann::ordered_json::parse(options->extra_options_json);
  extra[key] = value;
  options->extra_options_json = extra.dump();
}

// What evaluate detects with: every candidate (AP sweeps them all), and the
// operating point the options make of the model's, for the op/ metrics.
EvaluateCommandOptions WithOperatingPoint(EvaluateCommandOptions options,
                                          const TrainedModel& model) {
  options.evaluation.operating_point =
      options.detector.EffectiveOperatingPoint(model.operating_point);
  // Which hypothesis source detects (as the Detector decides), stored with
  // the run: history keeps learned and codebook runs on their own lines.
  AddStoredOption(
      &options,
      "hypotheses",
      UsesLearnedVoting(options.detector.voting, !model.vote_net.empty()) ? "learned" : "codebook");
  if (options.op_match_m > 0) options.evaluation.operating_point.match_m = options.op_match_m;
  options.detector.all_candidates = true;
  return options;
}

EvaluationOptions EvaluationOptionsOf(const EvaluateCommandOptions& options) {
  EvaluationOptions evaluation = options.evaluation;
  evaluation.max_distance_m = options.detector.max_range_m;
  return evaluation;
}

ShardHeader HeaderOf(const FrameSelection& selection,
                     const std::string& model_hash,
                     const EvaluateCommandOptions& options,
                     int shard,
                     int shards);

// A running evaluation's frames so far, in a shard file beside the dataset
// (`<db>.evaluate-<key>.partial`, the key naming model, frames and options),
// rewritten at most every FURN_EVALUATE_SAVE_SECONDS (default 10) seconds:
// a killed evaluation run again with the same model and options detects only
// the frames it had not saved. Off for shards and scorer samples.
class EvaluationProgress {
 public:
  EvaluationProgress(const std::string& db_path, ShardHeader header, bool enabled)
      : header_(std::move(header)), enabled_(enabled) {
    if (!enabled_) return;
    path_ =
        db_path + ".evaluate-" +
        ShortHash(header_.dataset_hash + "\n" + header_.model_hash + "\n" + header_.options_json) +
        ".partial";
    const char* env = std::getenv("FURN_EVALUATE_SAVE_SECONDS");
    if (env != nullptr) interval_s_ = std::max(0.0, std::atof(env));
  }

  // The frames a killed run of this evaluation saved, by position.
  std::map<int, EvaluatedFrame> Saved(bool quiet) const {
    std::map<int, EvaluatedFrame> saved;
    std::error_code ec;
    if (!enabled_ || !std::filesystem::exists(path_, ec)) return saved;
    try {
      for (EvaluatedFrame& frame : ReadShardFile(path_, header_)) {
        const int position = frame.position;
        saved.emplace(position, std::move(frame));
      }
    } catch (const InputError& e) {
      if (!quiet) std::fprintf(stderr, "note: %s; evaluating every frame\n", e.what());
      return {};
    }
    if (!quiet && !saved.empty())
      std::fprintf(stderr, "evaluate: resuming: %zu frames from %s\n", saved.size(), path_.c_str());
    return saved;
  }

  // After each frame: the frames so far, when the interval has passed.
  void Save(const std::vector<EvaluatedFrame>& frames, bool force = false) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (!force && std::chrono::duration<double>(now - last_).count() < interval_s_) return;
    WriteShardFile(path_, header_, frames);
    last_ = now;
  }

  void Remove() const {
    std::error_code ec;
    if (enabled_) std::filesystem::remove(path_, ec);
  }

 private:
  ShardHeader header_;
  bool enabled_ = false;
  std::string path_;
  double interval_s_ = 10;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// Detection in the selected frames at positions p with p % shard_count ==
// shard_index (every frame when shard_count is 0), in order; the frames in
// `saved` (a killed run's) are taken as they are, their truth attached again.
std::vector<EvaluatedFrame> DetectFrames(DatasetDb& dataset,
                                         const std::string& db_path,
                                         const Detector& detector,
                                         const FrameSelection& selection,
                                         const EvaluateCommandOptions& options,
                                         std::map<int, EvaluatedFrame> saved,
                                         EvaluationProgress* progress_file) {
  const ModelFacts facts = FactsOf(detector.model());
  const std::set<int64_t> estimated_pose =
      FramesWithEstimatedPose(dataset.GenerationOptions().value_or(""));
  const int selected = static_cast<int>(selection.frames.size());
  auto wanted = [&](int position) {
    return options.shard_count == 0 || position % options.shard_count == options.shard_index;
  };
  int total = 0;
  for (int p = 0; p < selected; ++p) total += wanted(p);
  std::vector<EvaluatedFrame> frames;
  Progress progress("evaluate", total, "frames");
  std::optional<RoomRecord> room;  // with images: the room of the frames being evaluated
  const ModelFacts saved_facts = TrainedFactsOf(detector.model());
  for (int p = 0; p < selected; ++p) {
    if (!wanted(p)) continue;
    const auto found = saved.find(p);
    if (found != saved.end() && found->second.outcome.frame_id == selection.FrameAt(p).id) {
      found->second.outcome.truth =
          TruthOf(selection.RoomAt(p), selection.FrameAt(p), saved_facts, options.fusion);
      frames.push_back(std::move(found->second));
      progress.Advance();
      continue;
    }
    const RoomRecord& listed = selection.RoomAt(p);
    if (!room || room->id != listed.id) room = dataset.ReadRoom(listed.id, /*with_images=*/true);
    const FrameRecord& frame = room->frames[selection.frames[p].frame];
    // A frame with nothing in range (the camera against a wall, a dead
    // sensor) has no detections; its objects count as missed or ignored.
    frames.push_back(EvaluateFrame(
        detector, *room, frame, estimated_pose.count(frame.id) > 0, facts, db_path, options));
    frames.back().position = p;
    progress_file->Save(frames);
    progress.Advance();
  }
  progress.Finish();
  return frames;
}

// What made a run's detections: a model file, or a file of detections
// another program wrote (whose frames may lack their times).
struct RunSource {
  std::string path, hash;
  bool timed = true;  // false: no latency metric
};

// The run of the evaluated frames (every frame of the selection, in order):
// metrics, curves, detections and timings, stored in the dataset.
EvaluateSummary StoreRun(DatasetDb& dataset,
                         const RunSource& source,
                         const FrameSelection& selection,
                         const EvaluateCommandOptions& options,
                         std::vector<EvaluatedFrame> frames) {
  EvaluateSummary summary;
  std::vector<FrameOutcome> outcomes;
  std::vector<RunDetectionRecord> detections;
  std::vector<RunFrameRecord> frame_records;
  for (EvaluatedFrame& evaluated : frames) {
    summary.frames_without_points += evaluated.status == DetectionStatus::kNoPointsInRange;
    summary.frames_without_floor += evaluated.status == DetectionStatus::kNoFloor;
    detections.insert(detections.end(), evaluated.detections.begin(), evaluated.detections.end());
    frame_records.push_back(evaluated.record);
    summary.scorer_samples.insert(summary.scorer_samples.end(),
                                  evaluated.scorer_samples.begin(),
                                  evaluated.scorer_samples.end());
    outcomes.push_back(std::move(evaluated.outcome));
  }
  summary.frames = static_cast<int>(outcomes.size());
  const EvaluationOptions evaluation = EvaluationOptionsOf(options);
  summary.result = EvaluateFrames(outcomes, evaluation);
  summary.result.metrics[MetricId::Plain(PlainMetric::kFramesWithoutPoints).Name()] =
      summary.frames_without_points;
  summary.result.metrics[MetricId::Plain(PlainMetric::kFramesWithoutFloor).Name()] =
      summary.frames_without_floor;
  if (!source.timed) {
    for (PlainMetric latency :
         {PlainMetric::kLatencyP50, PlainMetric::kLatencyP90, PlainMetric::kLatencyP99})
      summary.result.metrics.erase(MetricId::Plain(latency).Name());
  }

  RunRecord run = NewRunRecord(options.kind, options.label);
  run.model_path = source.path;
  run.model_hash = source.hash;
  run.dataset_hash = selection.dataset_hash;
  run.split = options.split;
  run.options_json = StoredOptionsJson(options, evaluation);
  run.results_json = RunResults::OfEvaluation(summary.result).Json();
  summary.run_id = dataset.WriteRun(run, summary.result.metrics, detections, frame_records);
  return summary;
}

ShardHeader HeaderOf(const FrameSelection& selection,
                     const std::string& model_hash,
                     const EvaluateCommandOptions& options,
                     int shard,
                     int shards) {
  return {shard,
          shards,
          selection.dataset_hash,
          model_hash,
          StoredOptionsJson(options, EvaluationOptionsOf(options))};
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The run's detections in the external format (evaluate --write-detections),
// one line per frame in the selection's order, written atomically.
void WriteDetectionsFile(const std::string& path,
                         const std::vector<EvaluatedFrame>& frames,
                         const std::string& model_path) {
  const std::string detector = std::string("furnidet ") + FURN_VERSION + " " +
                               std::filesystem::path(model_path).filename().string();
  std::string text;
  for (const EvaluatedFrame& frame : frames) {
    text += ExternalDetectionsLine(
        frame.outcome.frame_id, frame.outcome.detections, detector, frame.outcome.total_ms);
  }
  WriteFileAtomically(path, text);
}

}  // namespace

EvaluateSummary EvaluateModel(const std::string& model_path,
                              const std::string& db_path,
                              const EvaluateCommandOptions& command_options) {
  CheckEvaluateOptions(command_options);
  const auto start = std::chrono::steady_clock::now();
  // The dataset first: a mistyped path fails before the model loads, and
  // creates nothing. A shard only reads it (its tasks run side by side).
  const bool shard = command_options.shard_count > 0;
  DatasetDb dataset(db_path,
                    shard ? DatasetDb::Mode::kReadOnly : DatasetDb::Mode::kReadWriteExisting);
  const std::string model_hash = ModelFileHash(model_path);
  TrainedModel model = LoadTrainedModel(model_path);
  const EvaluateCommandOptions options = WithOperatingPoint(command_options, model);
  const std::string note = VoteNetInputNote(model, model_path, options.fusion.room_frames);
  if (!note.empty() && !shard) std::fprintf(stderr, "note: %s\n", note.c_str());
  const Detector detector(std::move(model), options.detector);
  const FrameSelection selection = SelectFrames(dataset, db_path, options);
  EvaluationProgress progress_file(db_path,
                                   HeaderOf(selection, model_hash, options, 0, 1),
                                   !shard && !options.collect_scorer_samples);
  std::vector<EvaluatedFrame> frames = DetectFrames(dataset,
                                                    db_path,
                                                    detector,
                                                    selection,
                                                    options,
                                                    progress_file.Saved(Progress::Quiet()),
                                                    &progress_file);
  EvaluateSummary summary;
  if (shard) {
    WriteShardFile(
        options.shard_out,
        HeaderOf(selection, model_hash, options, options.shard_index, options.shard_count),
        frames);
    summary.frames = static_cast<int>(frames.size());
  } else {
    if (!options.write_detections.empty())
      WriteDetectionsFile(options.write_detections, frames, model_path);
    summary = StoreRun(dataset, {model_path, model_hash}, selection, options, std::move(frames));
    progress_file.Remove();
  }
  summary.seconds = SecondsSince(start);
  return summary;
}

EvaluateSummary MergeEvaluation(const std::string& model_path,
                                const std::string& db_path,
                                const EvaluateCommandOptions& command_options,
                                const std::vector<std::string>& shard_paths) {
  CheckEvaluateOptions(command_options);
  Require(command_options.shard_count == 0, "a merge of shards is not itself a shard");
  Require(!command_options.collect_scorer_samples, "a merge of shards has no scorer samples");
  Require(!shard_paths.empty(), "no shard files to merge");
  const auto start = std::chrono::steady_clock::now();
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadWriteExisting);
  const std::string model_hash = ModelFileHash(model_path);
  const TrainedModel model = LoadTrainedModel(model_path);
  const EvaluateCommandOptions options = WithOperatingPoint(command_options, model);
  const ModelFacts facts = TrainedFactsOf(model);
  const FrameSelection selection = SelectFrames(dataset, db_path, options);
  const int shards = static_cast<int>(shard_paths.size());
  const int selected = static_cast<int>(selection.frames.size());
  // Every position of the selection from exactly the shard it belongs to.
  std::vector<std::optional<EvaluatedFrame>> slots(selected);
  for (int s = 0; s < shards; ++s) {
    for (EvaluatedFrame& frame :
         ReadShardFile(shard_paths[s], HeaderOf(selection, model_hash, options, s, shards))) {
      const int p = frame.position;
      Require(p >= 0 && p < selected && p % shards == s && !slots[p],
              shard_paths[s] + ": frame position " + std::to_string(p) +
                  " does not belong to shard " + std::to_string(s) + "/" + std::to_string(shards) +
                  " or comes twice");
      slots[p] = std::move(frame);
    }
  }
  std::vector<EvaluatedFrame> frames;
  for (int p = 0; p < selected; ++p) {
    const FrameRecord& frame = selection.FrameAt(p);
    Require(slots[p].has_value() && slots[p]->outcome.frame_id == frame.id,
            shard_paths[p % shards] + ": lacks frame " + std::to_string(frame.id) + " (position " +
                std::to_string(p) + "); rerun its task");
    slots[p]->outcome.truth = TruthOf(selection.RoomAt(p), frame, facts, options.fusion);
    frames.push_back(std::move(*slots[p]));
  }
  if (options.check_only) {
    EvaluateSummary summary;
    summary.frames = selected;
    summary.seconds = SecondsSince(start);
    return summary;
  }
  // The final step of a sharded evaluation may run again after it stored its
  // run (killed before its status was written): the same merge is not stored
  // twice.
  const std::string stored_options = StoredOptionsJson(options, EvaluationOptionsOf(options));
  for (const RunRecord& run : dataset.Runs()) {
    if (run.kind != options.kind || run.label != options.label || run.model_hash != model_hash ||
        run.dataset_hash != selection.dataset_hash || run.split != options.split ||
        run.options_json != stored_options)
      continue;
    EvaluateSummary summary;
    summary.run_id = run.id;
    summary.frames = selected;
    summary.already_stored = true;
    summary.result.metrics = dataset.RunMetrics(run.id);
    summary.seconds = SecondsSince(start);
    return summary;
  }
  if (!options.write_detections.empty())
    WriteDetectionsFile(options.write_detections, frames, model_path);
  EvaluateSummary summary =
      StoreRun(dataset, {model_path, model_hash}, selection, options, std::move(frames));
  summary.seconds = SecondsSince(start);
  return summary;
}

OperatingPoint ChooseOperatingPointOn(const TrainedModel& model,
                                      const std::string& db_path,
                                      const EvaluateCommandOptions& command_options) {
  CheckEvaluateOptions(command_options);
  Require(command_options.shard_count == 0, "an operating point is chosen on every frame at once");
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadOnly);
  const EvaluateCommandOptions options = WithOperatingPoint(command_options, model);
  const Detector detector(model, options.detector);
  const FrameSelection selection = SelectFrames(dataset, db_path, options);
  std::vector<FrameOutcome> outcomes;
  EvaluationProgress no_progress_file(db_path, {}, /*enabled=*/false);
  for (EvaluatedFrame& frame :
       DetectFrames(dataset, db_path, detector, selection, options, {}, &no_progress_file))
    outcomes.push_back(std::move(frame.outcome));
  return ChooseOperatingPoint(outcomes,
                              EvaluationOptionsOf(options),
                              kOperatingMatchM,
                              std::to_string(outcomes.size()) + " frames of " +
                                  std::filesystem::path(db_path).filename().string() + " (split " +
                                  EnumName(options.split) + ")");
}

}  // namespace furn

namespace furn {
namespace {

// What evaluation knows of the CAD models without a model file: those the
// dataset does not mark evaluation-only count as seen in training.
ModelFacts DatasetFactsOf(DatasetDb& dataset) {
  ModelFacts facts;
  for (const ModelRecord& model : dataset.ReadModels()) {
    if (!model.evaluation_only) facts.trained.insert(model.id);
  }
  return facts;
}

// One frame of another program's detections, moved into the labels' frame
// when they were found on an estimated floor.
EvaluatedFrame ExternalFrameOf(const ExternalFrame& external,
                               const RoomRecord& room,
                               const FrameRecord& frame,
                               const ModelFacts& facts,
                               const EvaluateCommandOptions& options) {
  EvaluatedFrame out;
  out.outcome.frame_id = frame.id;
  out.outcome.truth = TruthOf(room, frame, facts, options.fusion);
  Eigen::Isometry3d to_labels = Eigen::Isometry3d::Identity();
  if (external.detector_world_from_camera)
    to_labels = frame.world_from_camera * external.detector_world_from_camera->inverse();
  for (ScoredDetection d : external.detections) {
    static_cast<FurnitureBox&>(d) = MovedBox(d, to_labels);
    d.box3d = MovedOrientedBox(d.box3d, to_labels);
    out.outcome.detections.push_back(d);
    // Its detections are its candidates: what the funnel looks for near a
    // missed object.
    out.outcome.maxima.push_back(
        {d.furniture_class, d.x, d.y, d.score, HypothesisOutcome::kDetected});
    out.detections.push_back({frame.id,
                              d.furniture_class,
                              d.model_id,
                              d.x,
                              d.y,
                              d.box3d.centre.z() - d.box3d.size.z() / 2,
                              d.yaw,
                              d.score,
                              0,
                              0,
                              0});
  }
  out.outcome.total_ms = external.time_ms.value_or(0);
  nlohmann::json timings = nlohmann::json::object();
  if (external.time_ms) timings[EnumName(DetectionStage::kTotal)] = *external.time_ms;
  out.record = {frame.id, out.outcome.total_ms, timings.dump()};
  return out;
}

}  // namespace

EvaluateSummary EvaluateDetections(const std::string& detections_path,
                                   const std::string& db_path,
                                   const EvaluateCommandOptions& command_options) {
  CheckEvaluateOptions(command_options);
  Require(command_options.shard_count == 0 && !command_options.collect_scorer_samples,
          "scoring another program's detections is one step (no shards, no scorer samples)");
  const auto start = std::chrono::steady_clock::now();
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadWriteExisting);
  const ExternalDetections external = ReadExternalDetections(detections_path);
  EvaluateCommandOptions options = command_options;
  options.kind = "external";
  options.evaluation.paper_protocol = false;  // no Hough maxima
  options.evaluation.operating_point = options.detector.EffectiveOperatingPoint(OperatingPoint{});
  if (options.op_match_m > 0) options.evaluation.operating_point.match_m = options.op_match_m;
  AddStoredOption(
      &options, "detections", {{"files", external.files.size()}, {"detector", external.detector}});
  const FrameSelection selection = SelectFrames(dataset, db_path, options);
  const ModelFacts facts = DatasetFactsOf(dataset);
  std::set<int64_t> selected_ids;
  std::vector<EvaluatedFrame> frames;
  bool timed = true;
  for (int p = 0; p < static_cast<int>(selection.frames.size()); ++p) {
    const FrameRecord& frame = selection.FrameAt(p);
    const auto found = external.frames.find(frame.id);
    Require(found != external.frames.end(),
            detections_path + ": has no line for frame " + std::to_string(frame.id) + " (room " +
                std::to_string(selection.RoomAt(p).id) + ", split " +
                EnumName(selection.RoomAt(p).split) +
                "); a frame where nothing was found needs a line with \"detections\": []");
    frames.push_back(ExternalFrameOf(found->second, selection.RoomAt(p), frame, facts, options));
    frames.back().position = p;
    timed &= found->second.time_ms.has_value();
    selected_ids.insert(frame.id);
  }
  // Lines of frames outside the selection (other splits) are left out; a
  // frame the dataset does not have means detections of another dataset.
  for (const auto& [id, frame] : external.frames) {
    if (!selected_ids.count(id) && !dataset.RoomOfFrame(id))
      throw InputError(frame.where + ": \"frame\" " + std::to_string(id) + " is not a frame of " +
                       db_path + " (detections of another dataset?)");
  }
  EvaluateSummary summary = StoreRun(dataset,
                                     {detections_path, external.content_hash, timed},
                                     selection,
                                     options,
                                     std::move(frames));
  summary.seconds = SecondsSince(start);
  return summary;
}

}  // namespace furn
