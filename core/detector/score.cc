// Stage 8 of detection: the scorer's features of a verified fit, its
// calibrated probability (hypothesis_scorer.h), the gates, and the outcome;
// and FitAndVerify, which runs stages 6 to 8 for every hypothesis.
#include <algorithm>
#include <cmath>

#include "core/detector/detector_impl.h"
#include "core/util/parallel.h"

namespace furn {
namespace {

// A gate of a verified fit: the value must reach the limit (or, at_most,
// not exceed it), else the hypothesis stops with `outcome`.
struct Gate {
  HypothesisOutcome outcome;
  double value, limit;
  bool at_most;
};

}  // namespace

HypothesisScore Detector::ScoreHypothesis(const PreparedScan& scan,
                                          const DetectionDebug::Hypothesis& hypothesis,
                                          const HypothesisFit& fit,
                                          const FitVerification& verification) const {
  Require(fit.best.has_value(), "ScoreHypothesis needs a hypothesis with a fit");
  const Impl& impl = *impl_;
  const DetectorOptions& options = impl.options;
  const CandidateFit& best = *fit.best;
  HypothesisScore result;
  if (verification.scorer_gates) {
    result.explained_points =
        impl.fitters[best.model].CoveredIndices(fit.region.points, best.fit.pose);
    HypothesisFeatures f;
    f.furniture_class = hypothesis.furniture_class;
    f.log_vote_weight = static_cast<float>(std::log1p(hypothesis.vote_weight));
    f.relative_weight = static_cast<float>(hypothesis.relative_weight);
    f.segments = static_cast<float>(hypothesis.segments.size());
    f.covered = static_cast<float>(verification.covered);
    f.verification = static_cast<float>(verification.verification);
    f.seen_occupied = static_cast<float>(verification.seen_occupied);
    const VisibilityCounts& counts = best.counts;
    const int counted = counts.occupied + counts.occluded + counts.free;
    f.free_share = counted > 0 ? static_cast<float>(counts.free) / counted : 0.f;
    f.occluded_share = counted > 0 ? static_cast<float>(counts.occluded) / counted : 0.f;
    f.log_points_in_box = static_cast<float>(std::log1p(best.fit.inside));
    const ModelShape& shape = impl.model.model_shapes[best.model];
    const Eigen::Vector3f size = shape.high - shape.low;
    f.model_width = size.x();
    f.model_depth = size.y();
    f.model_height = size.z();
    for (int k : result.explained_points)
      f.observed_height = std::max(f.observed_height, fit.region.points[k].z());
    const PlanarPose& pose = best.fit.pose;
    f.range = Eigen::Vector2f(static_cast<float>(pose.x) - scan.sensor.x(),
                              static_cast<float>(pose.y) - scan.sensor.y())
                  .norm();
    f.second_fit_ratio = best.score > 0 ? static_cast<float>(fit.second_score / best.score) : 0.f;
    f.fits = static_cast<float>(fit.fits);
    f.candidate_rank = static_cast<float>(best.rank);
    f.log_points_in_reach = static_cast<float>(std::log1p(fit.region.points.size()));
    f.seen_through = static_cast<float>(verification.seen_through);
    f.render_support = static_cast<float>(verification.render_support);
    result.features = f;
  }
  // The first test the best fit fails is the hypothesis' outcome: the fixed
  // gates, or with a scorer the looser ones and its probability.
  const bool scored = impl.scored;
  result.score = best.score;
  if (scored) {
    result.score = result.features ? impl.scorer.Probability(result.features->Vector()) : 0;
    result.probability = result.score;
  }
  const Gate gates[] = {
      {HypothesisOutcome::kLowCoverage,
       verification.covered,
       scored ? options.scorer_min_covered_fraction : options.min_covered_fraction,
       false},
      {HypothesisOutcome::kLowVerification,
       verification.verification,
       scored ? options.scorer_min_verification : options.min_verification,
       false},
      {HypothesisOutcome::kLowSeenOccupied,
       verification.seen_occupied,
       scored ? options.scorer_min_seen_occupied : options.min_seen_occupied,
       false},
      {HypothesisOutcome::kSeenThrough,
       verification.seen_through,
       scored ? options.scorer_max_seen_through : 1.0,
       true},
      {HypothesisOutcome::kLowScore,
       result.score,
       scored ? options.min_probability : options.min_score,
       false}};
  for (const Gate& gate : gates) {
    if (gate.at_most ? gate.value <= gate.limit : gate.value >= gate.limit) continue;
    result.outcome = gate.outcome;
    result.failed_value = gate.value;
    break;
  }
  return result;
}

namespace {

// The detection an accepted hypothesis gives.
Detection DetectionOf(const DetectionDebug::Hypothesis& hypothesis,
                      const CandidateFit& best,
                      const HypothesisScore& score,
                      const TrainedModel& model) {
  Detection d;
  d.furniture_class = hypothesis.furniture_class;
  d.x = best.fit.pose.x;
  d.y = best.fit.pose.y;
  d.z = 0;
  d.yaw = best.fit.pose.yaw;
  d.model_index = best.model;
  d.model_name = model.model_names[best.model];
  d.score = score.score;
  d.vote_weight = hypothesis.vote_weight;
  d.verification = best.verification;
  d.covered_fraction = best.covered;
  return d;
}

}  // namespace

std::vector<FittedHypothesis> Detector::FitAndVerify(
    const PreparedScan& scan, std::vector<DetectionDebug::Hypothesis>* hypotheses) const {
  std::vector<FittedHypothesis> out(hypotheses->size());
  std::vector<int> ranked;  // the others had no support, or the same as another
  for (size_t h = 0; h < hypotheses->size(); ++h) {
    if (!(*hypotheses)[h].candidate_models.empty()) ranked.push_back(static_cast<int>(h));
  }
  std::vector<HypothesisFit> fits = FitHypotheses(scan, *hypotheses, ranked);
  ParallelFor(0, static_cast<int>(ranked.size()), [&](int k) {
    const int h = ranked[k];
    DetectionDebug::Hypothesis& hypothesis = (*hypotheses)[h];
    HypothesisFit& fit = fits[k];
    hypothesis.fits = std::move(fit.tried);
    hypothesis.outcome = HypothesisOutcome::kNoFit;
    if (!fit.best) return;
    const FitVerification verification = VerifyFit(scan, fit);
    HypothesisScore score = ScoreHypothesis(scan, hypothesis, fit, verification);
    hypothesis.features = score.features;
    if (score.features) {
      hypothesis.fit_x = fit.best->fit.pose.x;
      hypothesis.fit_y = fit.best->fit.pose.y;
    }
    if (impl_->scored) hypothesis.probability = score.probability;
    hypothesis.outcome = score.outcome;
    if (score.outcome != HypothesisOutcome::kDetected) {
      hypothesis.outcome_values[0] = score.failed_value;
      return;
    }
    CandidateFit& best = *fit.best;
    out[h].detection = DetectionOf(hypothesis, best, score, impl_->model);
    if (!score.features) {
      score.explained_points =
          impl_->fitters[best.model].CoveredIndices(fit.region.points, best.fit.pose);
    }
    for (int k : score.explained_points) out[h].support.push_back(fit.region.cloud_index[k]);
    out[h].fitted_points = std::move(best.posed);
  });
  return out;
}

}  // namespace furn
