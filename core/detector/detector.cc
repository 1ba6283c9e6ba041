#include "core/detector/detector.h"
#include "core/detector/voting_choice.h"

#include <algorithm>
#include <cstdio>

#include "core/detector/codebook_source.h"
#include "core/detector/detector_impl.h"
#include "core/detector/learned_source.h"
#include "core/geometry/scene.h"  // PoseXYZYaw
#include "core/geometry/view_share.h"
#include "core/util/error.h"

namespace furn {

void DetectorOptions::Check() const {
  Require(max_range_m > 0, "max range " + std::to_string(max_range_m) + " m must be > 0");
  Require(floor_band_m >= 0 && floor_band_m < 0.5, "floor band must be in 0..0.5 m");
  floor.Check();
  Require(max_segment_extent_m > 0, "max segment extent must be > 0");
  Require(cell_m >= 0.005 && cell_m <= 0.2,
          "vote cell " + std::to_string(cell_m) + " m must be in 0.005..0.2");
  Require(vote_sigma_m >= 0 && vote_sigma_m <= 0.5, "vote sigma must be in 0..0.5 m");
  Require(vote_height_tolerance_m >= 0, "vote height tolerance must be >= 0");
  Require(relative_threshold >= 0 && relative_threshold <= 1,
          "relative threshold " + std::to_string(relative_threshold) + " must be in 0..1");
  Require(absolute_threshold >= 0, "absolute threshold must be >= 0");
  Require(max_hypotheses_per_class >= 1, "max hypotheses per class must be >= 1");
  Require(support_radius_m > 0, "support radius must be > 0");
  Require(neighbours >= 1 && neighbours <= 1000, "neighbours must be in 1..1000");
  Require(top_models >= 1, "top models must be >= 1");
  fit.Check();
  Require(min_covered_fraction >= 0 && min_covered_fraction <= 1,
          "min covered fraction must be in 0..1");
  Require(occupancy_voxel_m >= 0.01 && occupancy_voxel_m <= 0.5,
          "occupancy voxel " + std::to_string(occupancy_voxel_m) + " m must be in 0.01..0.5");
  Require(occupied_weight > 0, "occupied weight must be > 0");
  Require(min_verification >= 0 && min_verification <= 1,
          "min verification " + std::to_string(min_verification) + " must be in 0..1");
  Require(max_footprint_overlap >= 0 && max_footprint_overlap <= 1,
          "max footprint overlap must be in 0..1");
  Require(min_score >= 0 && min_score <= 1, "min score must be in 0..1");
  Require(min_seen_occupied >= 0 && min_seen_occupied <= 1, "min seen occupied must be in 0..1");
  Require(max_shared_support >= 0 && max_shared_support <= 1, "max shared support must be in 0..1");
  Require(own_segment_share >= 0 && own_segment_share <= 1,
          "own segment share " + std::to_string(own_segment_share) + " must be in 0..1");
  Require(scorer_min_covered_fraction >= 0 && scorer_min_covered_fraction <= 1,
          "scorer min covered fraction must be in 0..1");
  Require(scorer_min_verification >= 0 && scorer_min_verification <= 1,
          "scorer min verification must be in 0..1");
  Require(scorer_min_seen_occupied >= 0 && scorer_min_seen_occupied <= 1,
          "scorer min seen occupied must be in 0..1");
  Require(min_probability >= 0 && min_probability <= 1, "min probability must be in 0..1");
  Require(scorer_max_seen_through >= 0 && scorer_max_seen_through <= 1,
          "scorer max seen through must be in 0..1");
  LearnedDecode().Check();
  Require(torch_threads >= 0 && torch_threads <= 256, "torch threads must be in 0..256");
  ResolvePrecision(network_precision);  // bf16 asked of a CPU without it
  Require(learned_fit_agree_m > 0 && learned_fit_agree_m <= 2,
          "learned fit agreement radius " + std::to_string(learned_fit_agree_m) +
              " must be in (0, 2] m");
  for (FurnitureClass c : kAllClasses) {
    const double value = class_min_score[static_cast<size_t>(c)];
    Require(value == -1 || (value >= 0 && value <= 1),
            std::string("the operating point of ") + ClassName(c) + " (" + std::to_string(value) +
                ") must be in 0..1, or -1 for the model's");
  }
}

OperatingPoint DetectorOptions::EffectiveOperatingPoint(const OperatingPoint& model_point) const {
  OperatingPoint point = model_point;
  for (size_t c = 0; c < kAllClasses.size(); ++c) {
    ClassOperatingPoint& entry = point.classes[c];
    if (all_candidates) {
      entry = ClassOperatingPoint{};
    } else if (class_min_score[c] >= 0 && class_min_score[c] != entry.min_score) {
      entry = ClassOperatingPoint{};  // its measured figures were of another threshold
      entry.min_score = class_min_score[c];
    }
  }
  return point;
}

BevDecodeOptions DetectorOptions::LearnedDecode() const {
  BevDecodeOptions decode = learned_decode;
  decode.max_distance_m = max_range_m;
  return decode;
}

Detector::Detector(TrainedModel model, const DetectorOptions& options)
    : impl_(std::make_unique<Impl>()) {
  options.Check();
  Impl& impl = *impl_;
  impl.model = std::move(model);
  impl.options = options;
  const TrainedModel& m = impl.model;
  Require(m.model_shapes.size() == m.model_names.size() && !m.part_models.empty(),
          "the trained model has no shapes or part subsets (train it again)");
  impl.entries_of_word.resize(m.vocabulary.NumWords());
  impl.entries_per_class.assign(m.vocabulary.NumWords(), {});
  for (size_t e = 0; e < m.shape.size(); ++e) {
    const ShapeEntry& entry = m.shape[e];
    impl.entries_of_word[entry.word].push_back(static_cast<int>(e));
    ++impl.entries_per_class[entry.word][static_cast<int>(entry.furniture_class)];
  }
  std::array<std::vector<double>, kClasses> widths;
  for (size_t k = 0; k < m.model_names.size(); ++k) {
    const ModelShape& shape = m.model_shapes[k];
    Require(!shape.points.empty(), "model " + m.model_names[k] + " has an empty shape");
    widths[static_cast<int>(m.model_classes[k])].push_back(
        (shape.high - shape.low).head<2>().maxCoeff());
    impl.fitters.emplace_back(shape, options.fit);
    impl.structure_height_m =
        std::max(impl.structure_height_m, shape.high.z() + static_cast<float>(options.fit.above_m));
  }
  for (int c = 0; c < kClasses; ++c) {  // the median model's width
    if (widths[c].empty()) continue;
    std::sort(widths[c].begin(), widths[c].end());
    impl.class_width[c] = widths[c][widths[c].size() / 2];
  }
  impl.parts = std::make_unique<PartSubsetIndex>(m.part_index);
  impl.scorer = HypothesisScorer::Deserialize(m.scorer, "the model's hypothesis scorer");
  impl.scored = options.use_scorer && !impl.scorer.empty();
  if (!m.render_meshes.empty())
    impl.mesh_caster = std::make_unique<ModelMeshCaster>(&impl.model.render_meshes);
  if (!m.vote_net.empty()) {
    impl.vote_net = VoteNet::Deserialize(m.vote_net, "the model's vote network");
    impl.vote_net.SetPrecision(options.network_precision);
  }
  Require(options.voting != VotingMode::kLearned || !impl.vote_net.empty(),
          "voting learned: the model holds no vote network (train one into it, or vote with "
          "the codebook)");
  impl.learned = UsesLearnedVoting(options.voting, !impl.vote_net.empty());
  impl.operating_point = options.EffectiveOperatingPoint(m.operating_point);
  if (impl.learned) {
    impl.source = std::make_unique<LearnedSource>(*this);
  } else {
    impl.source = std::make_unique<CodebookSource>(*this);
  }
}

Detector::~Detector() = default;

const TrainedModel& Detector::model() const { return impl_->model; }
const DetectorOptions& Detector::options() const { return impl_->options; }
const OperatingPoint& Detector::operating_point() const { return impl_->operating_point; }
bool Detector::scored() const { return impl_->scored; }
bool Detector::learned() const { return impl_->learned; }

DetectionBox BoxOf(const Detection& d, const TrainedModel& model) {
  DetectionBox box;
  const bool named =
      d.model_index >= 0 && d.model_index < static_cast<int>(model.model_shapes.size());
  if (named && !(d.width > 0 && d.depth > 0)) {
    box.low = model.model_shapes[d.model_index].low;
    box.high = model.model_shapes[d.model_index].high;
    return box;
  }
  constexpr float kHeightM[] = {0.9f, 0.85f, 0.75f, 0.85f, 0.85f};  // per class, enum order
  static_assert(sizeof(kHeightM) / sizeof(float) == kAllClasses.size());
  const Eigen::Vector2f half(static_cast<float>(d.width / 2), static_cast<float>(d.depth / 2));
  box.low << -half, 0;
  box.high << half, named ? model.model_shapes[d.model_index].high.z()
                          : kHeightM[static_cast<int>(d.furniture_class)];
  return box;
}

std::string DetectionDebug::Describe(const Hypothesis& h) {
  char text[96];
  switch (h.outcome) {
    case HypothesisOutcome::kNoSupport:
      return "no supporting segment";
    case HypothesisOutcome::kSameSupport:
      return "same support as a stronger maximum";
    case HypothesisOutcome::kNoFit:
      return "no fit";
    case HypothesisOutcome::kLowCoverage:
      std::snprintf(text, sizeof(text), "covers %.2f of the points", h.outcome_values[0]);
      return text;
    case HypothesisOutcome::kLowVerification:
      std::snprintf(text, sizeof(text), "verification %.2f", h.outcome_values[0]);
      return text;
    case HypothesisOutcome::kLowSeenOccupied:
      std::snprintf(text, sizeof(text), "seen occupied %.2f", h.outcome_values[0]);
      return text;
    case HypothesisOutcome::kSeenThrough:
      std::snprintf(text, sizeof(text), "seen through on %.2f of its pixels", h.outcome_values[0]);
      return text;
    case HypothesisOutcome::kLowScore:
      std::snprintf(text, sizeof(text), "score %.2f", h.outcome_values[0]);
      return text;
    case HypothesisOutcome::kSuppressed:
      if (h.learned) {
        std::snprintf(text,
                      sizeof(text),
                      "suppressed (a stronger maximum %.2f m away)",
                      h.learned->suppressed_by_m);
        return text;
      }
      std::snprintf(text,
                    sizeof(text),
                    "suppressed (shares %.2f, overlaps %.2f)",
                    h.outcome_values[0],
                    h.outcome_values[1]);
      return text;
    case HypothesisOutcome::kBelowOperatingPoint:
      std::snprintf(text,
                    sizeof(text),
                    "score %.2f below the operating point %.2f",
                    h.outcome_values[0],
                    h.outcome_values[1]);
      return text;
    case HypothesisOutcome::kDetected:
      return "detected";
  }
  return "unknown";
}

namespace {

// Each detection's share in view (Detection::in_view).
void SetShareInView(const PreparedScan& scan,
                    const DetectionInput& input,
                    const TrainedModel& model,
                    std::vector<Detection>* detections) {
  const std::optional<ViewFrustum> view =
      scan.intrinsics ? ViewFrustum::OfPinhole(*scan.intrinsics, scan.width, scan.height)
                      : ViewFrustum::OfPoints(input.points);
  if (!view) return;
  const Eigen::Isometry3d camera_from_world = scan.world_from_camera.inverse();
  for (Detection& d : *detections) {
    const DetectionBox box = BoxOf(d, model);
    d.in_view = ShareOfBoxInView(*view,
                                 camera_from_world * PoseXYZYaw(d.x, d.y, d.z, d.yaw),
                                 box.low.cast<double>(),
                                 box.high.cast<double>());
  }
}

}  // namespace

void KeepAtOperatingPoint(const OperatingPoint& point, Proposals* proposals) {
  std::vector<Candidate> kept;
  for (Candidate& candidate : proposals->candidates) {
    const Detection& d = candidate.detection;
    if (point.Keeps(d.furniture_class, d.score)) {
      kept.push_back(std::move(candidate));
      continue;
    }
    DetectionDebug::Hypothesis& h = proposals->hypotheses[candidate.hypothesis];
    h.outcome = HypothesisOutcome::kBelowOperatingPoint;
    h.outcome_values[0] = d.score;
    h.outcome_values[1] = point.MinScore(d.furniture_class);
  }
  proposals->candidates = std::move(kept);
}

DetectionResult Detector::Detect(const DetectionInput& input, bool keep_debug) const {
  DetectionResult result;
  StageTimer timer(&result.timings_ms);
  PreparedScan scan = PlaceScan(input);
  result.input_points = scan.input_points;
  if (scan.status != DetectionStatus::kDetected) {
    result.status = scan.status;
    result.message = scan.message;
    timer.Total();
    return result;
  }
  result.world_from_camera = scan.world_from_camera;
  result.floor_estimated = scan.floor_estimated;
  const HypothesisSource& source = *impl_->source;
  Proposals proposals = source.Propose(input, &scan, keep_debug, &timer, &result);
  result.scene_points = static_cast<int>(scan.view.cloud.size());
  result.segments = static_cast<int>(scan.view.segments.size());
  // The tail both sources share.
  KeepAtOperatingPoint(impl_->operating_point, &proposals);
  source.Refine(scan, &proposals, &timer);
  for (const Candidate& candidate : proposals.candidates)
    result.detections.push_back(candidate.detection);
  SetShareInView(scan, input, impl_->model, &result.detections);
  timer.Total();
  if (keep_debug) source.Record(scan, &proposals, &result.debug);
  result.debug.hypotheses = std::move(proposals.hypotheses);  // small: kept for evaluation too
  return result;
}

}  // namespace furn
