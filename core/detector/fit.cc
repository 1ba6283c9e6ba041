// Stage 6 of detection: the scene points around a hypothesis, and each
// candidate CAD model fitted to them by 3-DOF RANSAC + ICP (pose_fit.h),
// ranked by the paper's visibility score times the covered and seen shares.
#include <algorithm>
#include <map>

#include "core/detector/detector_impl.h"
#include "core/util/parallel.h"
#include "core/util/random.h"

namespace furn {
namespace {

// How far from the maximum the largest candidate can reach (m).
float Reach(const TrainedModel& model, const std::vector<int>& candidates, double max_offset_m) {
  float reach = 0;
  for (int m : candidates) {
    const ModelShape& shape = model.model_shapes[m];
    reach = std::max({reach,
                      shape.low.head<2>().norm(),
                      shape.high.head<2>().norm(),
                      Eigen::Vector2f(shape.low.x(), shape.high.y()).norm(),
                      Eigen::Vector2f(shape.high.x(), shape.low.y()).norm()});
  }
  return reach + static_cast<float>(max_offset_m);
}

// Scene points around the maximum within `reach`, structure left out, and
// the even subsample RANSAC fits to.
HypothesisRegion RegionAround(const PreparedScan& scan,
                              const DetectionDebug::Hypothesis& hypothesis,
                              float reach) {
  const ViewSegments& view = scan.view;
  HypothesisRegion region;
  for (size_t i = 0; i < view.cloud.size(); ++i) {
    const Eigen::Vector3f& p = view.cloud.points[i];
    if (scan.structure[i]) continue;
    if (Eigen::Vector2f(p.x() - hypothesis.x, p.y() - hypothesis.y).norm() <= reach) {
      region.fit_points.push_back(p);
      region.fit_normals.push_back(view.cloud.normals[i]);
      region.cloud_index.push_back(static_cast<int>(i));
    }
  }
  region.points = region.fit_points;
  region.fit_cloud_index = region.cloud_index;
  if (region.fit_points.size() > kMaxFitPoints) {  // an even subsample keeps RANSAC scoring cheap
    const double stride = static_cast<double>(region.fit_points.size()) / kMaxFitPoints;
    for (size_t k = 0; k < kMaxFitPoints; ++k) {
      const auto from = static_cast<size_t>(k * stride);
      region.fit_points[k] = region.fit_points[from];
      region.fit_normals[k] = region.fit_normals[from];
      region.fit_cloud_index[k] = region.fit_cloud_index[from];
    }
    region.fit_points.resize(kMaxFitPoints);
    region.fit_normals.resize(kMaxFitPoints);
    region.fit_cloud_index.resize(kMaxFitPoints);
  }
  return region;
}

}  // namespace

// The share of the points in the fit's box that the posed model explains,
// counting only the segments that lie mostly (own_segment_share) inside the
// box: a desk top over a chair pushed under it, or a shelf running past a
// cabinet, belongs to its own object and is not what the fit leaves
// unexplained. Points in no segment count as the fit's own.
double Detector::Impl::ExplainedOwnPoints(const PreparedScan& scan,
                                          int model_index,
                                          const PlanarPose& pose,
                                          const std::vector<Eigen::Vector3f>& scene_points,
                                          const std::vector<int>& cloud_index) const {
  const ModelShape& shape = model.model_shapes[model_index];
  const Eigen::Vector3f margin =
      Eigen::Vector3f::Constant(static_cast<float>(options.fit.inlier_m));
  const Eigen::Vector3f low = shape.low - margin;
  const Eigen::Vector3f high =
      shape.high + margin + Eigen::Vector3f(0, 0, static_cast<float>(options.fit.above_m));
  const PlanarTransform transform(pose);
  auto in_box = [&](const Eigen::Vector3f& p) {
    const Eigen::Vector3f q = transform.Inverse(p);
    return (q.array() >= low.array()).all() && (q.array() <= high.array()).all();
  };
  std::map<int, bool> own_segment;  // segment -> mostly inside the box
  auto own = [&](int point) {
    const int segment = scan.segment_of_point[point];
    if (segment < 0) return true;
    const auto found = own_segment.find(segment);
    if (found != own_segment.end()) return found->second;
    const std::vector<int>& members = scan.view.segments[segment];
    size_t inside = 0;
    for (int member : members) inside += in_box(scan.view.cloud.points[member]);
    const bool mostly = inside >= options.own_segment_share * members.size();
    own_segment.emplace(segment, mostly);
    return mostly;
  };
  const std::vector<int> covered = fitters[model_index].CoveredIndices(scene_points, pose);
  std::vector<char> is_covered(scene_points.size(), 0);
  for (int i : covered) is_covered[i] = 1;
  int own_inside = 0, own_covered = 0;
  for (size_t i = 0; i < scene_points.size(); ++i) {
    if (!in_box(scene_points[i]) || !own(cloud_index[i])) continue;
    ++own_inside;
    own_covered += is_covered[i];
  }
  return own_inside > 0 ? static_cast<double>(own_covered) / own_inside : 0;
}

std::optional<CandidateFit> Detector::FitCandidate(const PreparedScan& scan,
                                                   const DetectionDebug::Hypothesis& hypothesis,
                                                   const HypothesisRegion& region,
                                                   int hypothesis_index,
                                                   int rank) const {
  const Impl& impl = *impl_;
  const DetectorOptions& options = impl.options;
  const Eigen::Vector2f hint(static_cast<float>(hypothesis.x), static_cast<float>(hypothesis.y));
  CandidateFit candidate;
  candidate.model = hypothesis.candidate_models[rank];
  candidate.rank = rank;
  candidate.fit = impl.fitters[candidate.model].Fit(
      region.fit_points,
      region.fit_normals,
      hint,
      DeriveSeed(options.seed, static_cast<uint64_t>(hypothesis_index) * 64 + rank));
  if (!candidate.fit.found) return std::nullopt;
  candidate.covered = options.own_segment_share > 0
                          ? impl.ExplainedOwnPoints(scan,
                                                    candidate.model,
                                                    candidate.fit.pose,
                                                    region.fit_points,
                                                    region.fit_cloud_index)
                          : candidate.fit.Explained();
  const std::vector<Eigen::Vector3f>& shape_points =
      impl.model.model_shapes[candidate.model].points;
  candidate.posed.reserve(shape_points.size());
  const PlanarTransform transform(candidate.fit.pose);
  for (const Eigen::Vector3f& p : shape_points) candidate.posed.push_back(transform.Apply(p));
  candidate.counts =
      CountVisibility(*scan.occupancy, candidate.posed, static_cast<float>(options.floor_band_m));
  candidate.verification = candidate.counts.Score(options.occupied_weight);
  candidate.score = candidate.verification * candidate.covered * candidate.counts.SeenOccupied();
  return candidate;
}

void HypothesisFit::Add(CandidateFit candidate) {
  ++fits;
  const PlanarPose& pose = candidate.fit.pose;
  tried.push_back({candidate.model,
                   pose.x,
                   pose.y,
                   pose.yaw,
                   candidate.covered,
                   candidate.verification,
                   candidate.score});
  const double best_score = best ? best->score : -1;
  if (candidate.score <= best_score) {
    second_score = std::max(second_score, candidate.score);
    return;
  }
  second_score = std::max(second_score, best_score);
  best = std::move(candidate);
}

HypothesisRegion Detector::RegionOf(const PreparedScan& scan,
                                    const DetectionDebug::Hypothesis& hypothesis) const {
  return RegionAround(
      scan,
      hypothesis,
      Reach(impl_->model, hypothesis.candidate_models, impl_->options.fit.max_offset_m));
}

HypothesisFit Detector::FitHypothesis(const PreparedScan& scan,
                                      const DetectionDebug::Hypothesis& hypothesis,
                                      int hypothesis_index) const {
  HypothesisFit result;
  if (hypothesis.candidate_models.empty()) return result;
  result.region = RegionOf(scan, hypothesis);
  for (size_t c = 0; c < hypothesis.candidate_models.size(); ++c) {
    std::optional<CandidateFit> candidate =
        FitCandidate(scan, hypothesis, result.region, hypothesis_index, static_cast<int>(c));
    if (candidate) result.Add(std::move(*candidate));
  }
  return result;
}

std::vector<HypothesisFit> Detector::FitHypotheses(
    const PreparedScan& scan,
    const std::vector<DetectionDebug::Hypothesis>& hypotheses,
    const std::vector<int>& indices) const {
  std::vector<HypothesisFit> results(indices.size());
  // Regions first, then every (hypothesis, candidate) pair on its own: a
  // frame of one hypothesis and three candidates fits on three cores, not
  // one. Each pair's RANSAC is seeded by its own indices and the candidates
  // are added in rank order, so the fits are FitHypothesis's to the bit.
  std::vector<std::pair<int, int>> pairs;  // (position in indices, rank)
  for (size_t k = 0; k < indices.size(); ++k) {
    const size_t candidates = hypotheses[indices[k]].candidate_models.size();
    for (size_t c = 0; c < candidates; ++c)
      pairs.emplace_back(static_cast<int>(k), static_cast<int>(c));
  }
  ParallelFor(0, static_cast<int>(indices.size()), [&](int k) {
    const DetectionDebug::Hypothesis& hypothesis = hypotheses[indices[k]];
    if (!hypothesis.candidate_models.empty()) results[k].region = RegionOf(scan, hypothesis);
  });
  std::vector<std::optional<CandidateFit>> fitted(pairs.size());
  ParallelFor(0, static_cast<int>(pairs.size()), [&](int p) {
    const auto [k, rank] = pairs[p];
    fitted[p] = FitCandidate(scan, hypotheses[indices[k]], results[k].region, indices[k], rank);
  });
  for (size_t p = 0; p < pairs.size(); ++p) {
    if (fitted[p]) results[pairs[p].first].Add(std::move(*fitted[p]));
  }
  return results;
}

}  // namespace furn
