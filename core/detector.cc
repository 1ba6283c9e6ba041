#include "core/detector.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <unordered_set>

#include "core/error.h"
#include "core/occupancy.h"
#include "core/parallel.h"
#include "core/random.h"

namespace furn {
namespace {

using Clock = std::chrono::steady_clock;

constexpr int kClasses = static_cast<int>(kAllClasses.size());
constexpr double kSameSupport = 0.8;  // shared share of segments making two maxima one

class StageTimer {
 public:
  explicit StageTimer(std::vector<std::pair<std::string, double>>* out) : out_(out) {}
  void Lap(const std::string& stage) {
    const auto now = Clock::now();
    out_->emplace_back(stage, std::chrono::duration<double, std::milli>(now - last_).count());
    last_ = now;
  }
  void Restart() { last_ = Clock::now(); }
  void Total() {
    out_->emplace_back("total",
                       std::chrono::duration<double, std::milli>(Clock::now() - start_).count());
  }

 private:
  std::vector<std::pair<std::string, double>>* out_;
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_ = start_;
};

// The bounding box of a segment's points.
Eigen::AlignedBox3f SegmentBox(const PointCloud& cloud, const std::vector<int>& segment) {
  Eigen::AlignedBox3f box;
  for (int i : segment) box.extend(cloud.points[i]);
  return box;
}

}  // namespace

std::vector<char> FindStructure(const ViewSegments& view,
                                double max_extent,
                                float max_height,
                                std::vector<char>* segment_flags) {
  constexpr float kOnPlane = 0.04f;    // m
  constexpr float kSpanMargin = 0.1f;  // m
  const PointCloud& cloud = view.cloud;
  std::vector<char> structure(cloud.size(), 0);
  struct Plane {
    Eigen::Vector3f centre, normal, along;  // along: horizontal, in the plane
    float low, high;                        // span along `along`
  };
  std::vector<Plane> planes;
  for (const std::vector<int>& segment : view.segments) {
    const Eigen::AlignedBox3f box = SegmentBox(cloud, segment);
    if (box.sizes().maxCoeff() <= max_extent && box.max().z() <= max_height) continue;
    for (int i : segment) structure[i] = 1;
    Eigen::Vector3f centre = Eigen::Vector3f::Zero();
    for (int i : segment) centre += cloud.points[i];
    centre /= static_cast<float>(segment.size());
    Eigen::Matrix3f scatter = Eigen::Matrix3f::Zero();
    for (int i : segment) {
      const Eigen::Vector3f d = cloud.points[i] - centre;
      scatter += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver(scatter);
    const Eigen::Vector3f normal = solver.eigenvectors().col(0);
    const float thickness = std::sqrt(solver.eigenvalues()(0) / segment.size());
    if (std::abs(normal.z()) > 0.2f || thickness > kOnPlane / 2) continue;  // not a vertical plane
    Plane plane{
        centre, normal, Eigen::Vector3f(-normal.y(), normal.x(), 0).normalized(), 1e9f, -1e9f};
    for (int i : segment) {
      const float t = plane.along.dot(cloud.points[i] - centre);
      plane.low = std::min(plane.low, t);
      plane.high = std::max(plane.high, t);
    }
    planes.push_back(plane);
  }
  for (const Plane& plane : planes) {
    for (size_t i = 0; i < cloud.size(); ++i) {
      const Eigen::Vector3f d = cloud.points[i] - plane.centre;
      const float t = plane.along.dot(d);
      if (std::abs(plane.normal.dot(d)) <= kOnPlane && t >= plane.low - kSpanMargin &&
          t <= plane.high + kSpanMargin) {
        structure[i] = 1;
      }
    }
  }
  segment_flags->assign(view.segments.size(), 0);
  for (size_t s = 0; s < view.segments.size(); ++s) {
    size_t flagged = 0;
    for (int i : view.segments[s]) flagged += structure[i];
    (*segment_flags)[s] = 2 * flagged > view.segments[s].size();
  }
  return structure;
}

namespace {

// One point per voxel (the first): the ray ends of the occupancy grid.
std::vector<Eigen::Vector3f> ThinOut(const std::vector<Eigen::Vector3f>& points, double voxel_m) {
  std::unordered_set<uint64_t> taken;
  std::vector<Eigen::Vector3f> kept;
  for (const Eigen::Vector3f& p : points) {
    uint64_t key = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const auto cell = static_cast<uint64_t>(std::floor(p[axis] / voxel_m) + (1 << 20));
      key = (key << 21) | (cell & ((1u << 21) - 1));
    }
    if (taken.insert(key).second) kept.push_back(p);
  }
  return kept;
}

// The footprint of `shape` posed at `pose`, as an OpenCV rotated rectangle.
cv::RotatedRect Footprint(const ModelShape& shape, const PlanarPose& pose) {
  const Eigen::Vector3f centre = pose.Apply((shape.low + shape.high) / 2);
  const Eigen::Vector3f size = shape.high - shape.low;
  return cv::RotatedRect(cv::Point2f(centre.x(), centre.y()),
                         cv::Size2f(size.x(), size.y()),
                         static_cast<float>(pose.yaw * 180 / M_PI));
}

// Intersection area of two footprints over the smaller one's area.
double FootprintOverlap(const cv::RotatedRect& a, const cv::RotatedRect& b) {
  std::vector<cv::Point2f> region;
  if (cv::rotatedRectangleIntersection(a, b, region) == cv::INTERSECT_NONE || region.size() < 3)
    return 0;
  std::vector<cv::Point2f> hull;
  cv::convexHull(region, hull);
  const double smaller = std::min(a.size.area(), b.size.area());
  return smaller > 0 ? cv::contourArea(hull) / smaller : 0;
}

}  // namespace

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
}

struct Detector::Impl {
  TrainedModel model;
  DetectorOptions options;
  std::vector<std::vector<int>> entries_of_word;             // shape entries per word
  std::vector<std::array<int, kClasses>> entries_per_class;  // #(A_i, o)
  std::array<double, kClasses> class_width{};  // median footprint width per class (m); 0: none
  std::vector<ModelFitter> fitters;            // one per model
  // Segments reaching higher than this (the tallest model plus the fit's
  // above_m) are structure, like walls: no model can explain them.
  float structure_height_m = 0;
  std::unique_ptr<PartSubsetIndex> parts;
  HypothesisScorer scorer;  // empty: the fixed gates decide
  bool scored = false;      // the scorer decides (the model has one and use_scorer)
  // Ray casts the models' meshes for render-and-compare; null for a model
  // file without meshes (its shape samples are splatted instead).
  std::unique_ptr<ModelMeshCaster> mesh_caster;

  // The hypotheses of one class from its smoothed grid.
  std::vector<DetectionDebug::Hypothesis> Maxima(const cv::Mat& grid,
                                                 int class_index,
                                                 const Eigen::Vector2f& origin,
                                                 DetectionDebug::VoteGrid* debug) const;
  // The segments behind a hypothesis and its candidate CAD models.
  std::map<int, double> Support(const std::vector<HoughVote>& class_votes,
                                DetectionDebug::Hypothesis* hypothesis) const;
  void Rank(const std::map<int, double>& support,
            const std::vector<std::vector<int>>& segment_neighbours,
            DetectionDebug::Hypothesis* hypothesis) const;
  // The best-scoring fit of the candidates, if it passes the checks.
  double ExplainedOwnPoints(const PreparedScan& scan,
                            int model_index,
                            const PlanarPose& pose,
                            const std::vector<Eigen::Vector3f>& scene_points,
                            const std::vector<int>& cloud_index) const;
  void FitAndVerify(const PreparedScan& scan,
                    int hypothesis_index,
                    DetectionDebug::Hypothesis* hypothesis,
                    FittedHypothesis* out) const;
};

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
}

Detector::~Detector() = default;

const TrainedModel& Detector::model() const { return impl_->model; }
const DetectorOptions& Detector::options() const { return impl_->options; }
bool Detector::scored() const { return impl_->scored; }

std::vector<DetectionDebug::Hypothesis> Detector::Impl::Maxima(
    const cv::Mat& grid,
    int class_index,
    const Eigen::Vector2f& origin,
    DetectionDebug::VoteGrid* debug) const {
  double low = 0, high = 0;
  cv::minMaxLoc(grid, &low, &high);
  const double threshold =
      std::max(low + options.relative_threshold * (high - low), options.absolute_threshold);
  debug->threshold = threshold;
  std::vector<DetectionDebug::Hypothesis> maxima;
  if (high <= 0) return maxima;
  // Local maxima in a window half the class's (median) width across: equal
  // to the grid's maximum filter there (the paper's window).
  const int half =
      std::max(1, static_cast<int>(std::lround(0.25 * class_width[class_index] / options.cell_m)));
  cv::Mat dilated;
  cv::dilate(
      grid, dilated, cv::getStructuringElement(cv::MORPH_RECT, {2 * half + 1, 2 * half + 1}));
  std::vector<std::pair<float, int>> candidates;  // value, cell
  for (int r = 0; r < grid.rows; ++r) {
    const float* g = grid.ptr<float>(r);
    const float* d = dilated.ptr<float>(r);
    for (int c = 0; c < grid.cols; ++c) {
      if (g[c] > 0 && g[c] >= threshold && g[c] >= d[c])
        candidates.emplace_back(g[c], r * grid.cols + c);
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  for (const auto& [value, cell] : candidates) {
    const int r = cell / grid.cols, c = cell % grid.cols;
    // Plateaus give several equal cells: keep the first of each window.
    bool near_kept = false;
    for (const DetectionDebug::Hypothesis& kept : maxima) {
      const double dc = (kept.x - origin.x()) / options.cell_m - 0.5 - c;
      const double dr = (kept.y - origin.y()) / options.cell_m - 0.5 - r;
      near_kept |= std::abs(dc) <= half && std::abs(dr) <= half;
    }
    if (near_kept) continue;
    DetectionDebug::Hypothesis hypothesis;
    hypothesis.furniture_class = kAllClasses[class_index];
    hypothesis.x = origin.x() + (c + 0.5) * options.cell_m;
    hypothesis.y = origin.y() + (r + 0.5) * options.cell_m;
    hypothesis.vote_weight = value;
    hypothesis.relative_weight = high > low ? (value - low) / (high - low) : 0.0;
    maxima.push_back(hypothesis);
    if (static_cast<int>(maxima.size()) >= options.max_hypotheses_per_class) break;
  }
  return maxima;
}

std::map<int, double> Detector::Impl::Support(const std::vector<HoughVote>& class_votes,
                                              DetectionDebug::Hypothesis* hypothesis) const {
  // Segments that voted for this class near the maximum, with their weight there.
  const float radius2 = static_cast<float>(options.support_radius_m * options.support_radius_m);
  std::map<int, double> support;
  for (const HoughVote& vote : class_votes) {
    const float dx = vote.x - static_cast<float>(hypothesis->x);
    const float dy = vote.y - static_cast<float>(hypothesis->y);
    if (dx * dx + dy * dy <= radius2) support[vote.segment] += vote.weight;
  }
  for (const auto& [segment, weight] : support) hypothesis->segments.push_back(segment);
  return support;
}

void Detector::Impl::Rank(const std::map<int, double>& support,
                          const std::vector<std::vector<int>>& segment_neighbours,
                          DetectionDebug::Hypothesis* hypothesis) const {
  if (support.empty()) {
    hypothesis->outcome = HypothesisOutcome::kNoSupport;
    return;
  }
  // CAD models of this class ranked by the part subsets nearest to each
  // supporting segment: a neighbour at rank r adds weight / (r + 1).
  std::map<int, double> model_score;
  for (const auto& [segment, weight] : support) {
    const std::vector<int>& neighbours = segment_neighbours[segment];
    for (size_t r = 0; r < neighbours.size(); ++r) {
      const int m = model.part_models[neighbours[r]];
      if (model.model_classes[m] == hypothesis->furniture_class) model_score[m] += weight / (r + 1);
    }
  }
  std::vector<std::pair<double, int>> ranked;
  for (const auto& [m, score] : model_score) ranked.emplace_back(-score, m);
  std::sort(ranked.begin(), ranked.end());
  for (const auto& [negative_score, m] : ranked) {
    if (static_cast<int>(hypothesis->candidate_models.size()) < options.top_models)
      hypothesis->candidate_models.push_back(m);
  }
  // Too few ranked: the class's other models, in catalog order.
  for (size_t m = 0; m < model.model_classes.size(); ++m) {
    if (static_cast<int>(hypothesis->candidate_models.size()) >= options.top_models) break;
    if (model.model_classes[m] == hypothesis->furniture_class && model_score.count(m) == 0)
      hypothesis->candidate_models.push_back(static_cast<int>(m));
  }
}

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

void Detector::Impl::FitAndVerify(const PreparedScan& scan,
                                  int hypothesis_index,
                                  DetectionDebug::Hypothesis* hypothesis,
                                  FittedHypothesis* out) const {
  if (hypothesis->candidate_models.empty()) return;
  const ViewSegments& view = scan.view;
  // Scene points around the maximum, within reach of the largest candidate.
  float reach = 0;
  for (int m : hypothesis->candidate_models) {
    const ModelShape& shape = model.model_shapes[m];
    reach = std::max({reach,
                      shape.low.head<2>().norm(),
                      shape.high.head<2>().norm(),
                      Eigen::Vector2f(shape.low.x(), shape.high.y()).norm(),
                      Eigen::Vector2f(shape.high.x(), shape.low.y()).norm()});
  }
  reach += static_cast<float>(options.fit.max_offset_m);
  std::vector<Eigen::Vector3f> scene_points, scene_normals;
  std::vector<int> region;  // cloud indices of the points within reach
  for (size_t i = 0; i < view.cloud.size(); ++i) {
    const Eigen::Vector3f& p = view.cloud.points[i];
    if (scan.structure[i]) continue;
    if (Eigen::Vector2f(p.x() - hypothesis->x, p.y() - hypothesis->y).norm() <= reach) {
      scene_points.push_back(p);
      scene_normals.push_back(view.cloud.normals[i]);
      region.push_back(static_cast<int>(i));
    }
  }
  std::vector<Eigen::Vector3f> region_points = scene_points;
  std::vector<int> fit_index = region;   // cloud index of each fitted scene point
  constexpr size_t kMaxFitPoints = 800;  // an even subsample keeps RANSAC scoring cheap
  if (scene_points.size() > kMaxFitPoints) {
    const double stride = static_cast<double>(scene_points.size()) / kMaxFitPoints;
    for (size_t k = 0; k < kMaxFitPoints; ++k) {
      scene_points[k] = scene_points[static_cast<size_t>(k * stride)];
      scene_normals[k] = scene_normals[static_cast<size_t>(k * stride)];
      fit_index[k] = fit_index[static_cast<size_t>(k * stride)];
    }
    scene_points.resize(kMaxFitPoints);
    scene_normals.resize(kMaxFitPoints);
    fit_index.resize(kMaxFitPoints);
  }
  const Eigen::Vector2f hint(static_cast<float>(hypothesis->x), static_cast<float>(hypothesis->y));
  // Every candidate fitted; the best by the ranking score is the
  // hypothesis' fit: the paper's visibility score, times the share of the
  // points in the model's box it explains, times the share of its observable
  // surface the sensor actually saw (occluded points neither help nor hurt).
  struct Candidate {
    int model = -1, rank = 0;
    PoseFit fit;
    VisibilityCounts counts;
    double covered = 0, verification = 0, score = -1;
    std::vector<Eigen::Vector3f> posed;
  };
  Candidate best;
  double second_score = 0;
  int fits = 0;
  hypothesis->outcome = HypothesisOutcome::kNoFit;
  for (size_t c = 0; c < hypothesis->candidate_models.size(); ++c) {
    Candidate candidate;
    candidate.model = hypothesis->candidate_models[c];
    candidate.rank = static_cast<int>(c);
    candidate.fit = fitters[candidate.model].Fit(
        scene_points,
        scene_normals,
        hint,
        DeriveSeed(options.seed, static_cast<uint64_t>(hypothesis_index) * 64 + c));
    if (!candidate.fit.found) continue;
    ++fits;
    candidate.covered =
        options.own_segment_share > 0
            ? ExplainedOwnPoints(scan, candidate.model, candidate.fit.pose, scene_points, fit_index)
            : candidate.fit.Explained();
    const std::vector<Eigen::Vector3f>& shape_points = model.model_shapes[candidate.model].points;
    candidate.posed.reserve(shape_points.size());
    const PlanarTransform transform(candidate.fit.pose);
    for (const Eigen::Vector3f& p : shape_points) candidate.posed.push_back(transform.Apply(p));
    candidate.counts =
        CountVisibility(*scan.occupancy, candidate.posed, static_cast<float>(options.floor_band_m));
    candidate.verification = candidate.counts.Score(options.occupied_weight);
    candidate.score = candidate.verification * candidate.covered * candidate.counts.SeenOccupied();
    const PlanarPose& pose = candidate.fit.pose;
    hypothesis->fits.push_back({candidate.model,
                                pose.x,
                                pose.y,
                                pose.yaw,
                                candidate.covered,
                                candidate.verification,
                                candidate.score});
    if (candidate.score <= best.score) {
      second_score = std::max(second_score, candidate.score);
      continue;
    }
    second_score = std::max(second_score, best.score);
    best = std::move(candidate);
  }
  if (best.model < 0) return;

  const int m = best.model;
  const PlanarPose& pose = best.fit.pose;
  const double seen = best.counts.SeenOccupied();
  std::vector<int> covered_points;  // of the region: for the features, or the detection's support
  // Render-and-compare of the best fit from the actual camera.
  double seen_through = -1, render_support = -1;
  if (scan.intrinsics) {
    const Eigen::Isometry3f camera_from_world = scan.world_from_camera.inverse().cast<float>();
    RenderComparison comparison;
    if (mesh_caster) {
      Eigen::Isometry3f world_from_model = Eigen::Isometry3f::Identity();
      world_from_model.translation() =
          Eigen::Vector3f(static_cast<float>(pose.x), static_cast<float>(pose.y), 0.f);
      world_from_model.linear() =
          Eigen::AngleAxisf(static_cast<float>(pose.yaw), Eigen::Vector3f::UnitZ())
              .toRotationMatrix();
      comparison = mesh_caster->Compare(m,
                                        camera_from_world * world_from_model,
                                        scan.depth,
                                        scan.width,
                                        scan.height,
                                        *scan.intrinsics,
                                        static_cast<float>(options.floor_band_m));
    } else {
      std::vector<Eigen::Vector3f> in_camera;
      in_camera.reserve(best.posed.size());
      for (const Eigen::Vector3f& p : best.posed) {
        if (p.z() >= options.floor_band_m) in_camera.push_back(camera_from_world * p);
      }
      comparison = CompareRendered(in_camera,
                                   scan.depth,
                                   scan.width,
                                   scan.height,
                                   *scan.intrinsics,
                                   static_cast<float>(model.options.shape_voxel_m));
    }
    seen_through = comparison.ViolationShare();
    render_support = comparison.SupportShare();
  }
  const bool candidate_gates = best.covered >= options.scorer_min_covered_fraction &&
                               best.verification >= options.scorer_min_verification &&
                               seen >= options.scorer_min_seen_occupied;
  if (candidate_gates) {
    // The scorer's view of the hypothesis (hypothesis_scorer.h, in order).
    HypothesisFeatures& f = hypothesis->features;
    f.fill(0);
    f[static_cast<int>(hypothesis->furniture_class)] = 1;
    f[4] = static_cast<float>(std::log1p(hypothesis->vote_weight));
    f[5] = static_cast<float>(hypothesis->relative_weight);
    f[6] = static_cast<float>(hypothesis->segments.size());
    f[7] = static_cast<float>(best.covered);
    f[8] = static_cast<float>(best.verification);
    f[9] = static_cast<float>(seen);
    const int counted = best.counts.occupied + best.counts.occluded + best.counts.free;
    f[10] = counted > 0 ? static_cast<float>(best.counts.free) / counted : 0.f;
    f[11] = counted > 0 ? static_cast<float>(best.counts.occluded) / counted : 0.f;
    f[12] = static_cast<float>(std::log1p(best.fit.inside));
    const Eigen::Vector3f size = model.model_shapes[m].high - model.model_shapes[m].low;
    f[13] = size.x();
    f[14] = size.y();
    f[15] = size.z();
    covered_points = fitters[m].CoveredIndices(region_points, pose);
    float observed_height = 0;
    for (int k : covered_points) observed_height = std::max(observed_height, region_points[k].z());
    f[16] = observed_height;
    f[17] = Eigen::Vector2f(static_cast<float>(pose.x) - scan.sensor.x(),
                            static_cast<float>(pose.y) - scan.sensor.y())
                .norm();
    f[18] = best.score > 0 ? static_cast<float>(second_score / best.score) : 0.f;
    f[19] = static_cast<float>(fits);
    f[20] = static_cast<float>(best.rank);
    f[21] = static_cast<float>(std::log1p(region_points.size()));
    f[22] = static_cast<float>(seen_through);
    f[23] = static_cast<float>(render_support);
    hypothesis->has_features = true;
    hypothesis->fit_x = pose.x;
    hypothesis->fit_y = pose.y;
  }

  // The first test the best fit fails is the hypothesis' outcome: the fixed
  // gates, or with a scorer the looser ones and its probability.
  double score = best.score;
  if (scored) {
    score = candidate_gates ? scorer.Probability(hypothesis->features) : 0;
    hypothesis->probability = score;
  }
  struct Gate {
    HypothesisOutcome outcome;
    double value, limit;
    bool at_most;  // the value must not exceed the limit (else: reach it)
  };
  const Gate gates[] = {
      {HypothesisOutcome::kLowCoverage,
       best.covered,
       scored ? options.scorer_min_covered_fraction : options.min_covered_fraction,
       false},
      {HypothesisOutcome::kLowVerification,
       best.verification,
       scored ? options.scorer_min_verification : options.min_verification,
       false},
      {HypothesisOutcome::kLowSeenOccupied,
       seen,
       scored ? options.scorer_min_seen_occupied : options.min_seen_occupied,
       false},
      {HypothesisOutcome::kSeenThrough,
       seen_through,
       scored ? options.scorer_max_seen_through : 1.0,
       true},
      {HypothesisOutcome::kLowScore,
       score,
       scored ? options.min_probability : options.min_score,
       false}};
  hypothesis->outcome = HypothesisOutcome::kDetected;
  for (const Gate& gate : gates) {
    if (gate.at_most ? gate.value <= gate.limit : gate.value >= gate.limit) continue;
    hypothesis->outcome = gate.outcome;
    hypothesis->outcome_values[0] = gate.value;
    return;
  }
  Detection d;
  d.furniture_class = hypothesis->furniture_class;
  d.x = pose.x;
  d.y = pose.y;
  d.z = 0;
  d.yaw = pose.yaw;
  d.model_index = m;
  d.model_name = model.model_names[m];
  d.score = score;
  d.vote_weight = hypothesis->vote_weight;
  d.verification = best.verification;
  d.covered_fraction = best.covered;
  out->detection = d;
  out->fitted_points = std::move(best.posed);
  if (!hypothesis->has_features) covered_points = fitters[m].CoveredIndices(region_points, pose);
  for (int k : covered_points) out->support.push_back(region[k]);
}

const char* OutcomeName(HypothesisOutcome outcome) {
  switch (outcome) {
    case HypothesisOutcome::kNoSupport:
      return "no_support";
    case HypothesisOutcome::kSameSupport:
      return "same_support";
    case HypothesisOutcome::kNoFit:
      return "no_fit";
    case HypothesisOutcome::kLowCoverage:
      return "low_coverage";
    case HypothesisOutcome::kLowVerification:
      return "low_verification";
    case HypothesisOutcome::kLowSeenOccupied:
      return "low_seen_occupied";
    case HypothesisOutcome::kSeenThrough:
      return "seen_through";
    case HypothesisOutcome::kLowScore:
      return "low_score";
    case HypothesisOutcome::kSuppressed:
      return "suppressed";
    case HypothesisOutcome::kDetected:
      return "detected";
  }
  return "unknown";
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
      std::snprintf(text,
                    sizeof(text),
                    "suppressed (shares %.2f, overlaps %.2f)",
                    h.outcome_values[0],
                    h.outcome_values[1]);
      return text;
    case HypothesisOutcome::kDetected:
      return "detected";
  }
  return "unknown";
}

PreparedScan Detector::Prepare(const DetectionInput& input) const {
  const Impl& impl = *impl_;
  const DetectorOptions& options = impl.options;
  PreparedScan scan;
  StageTimer timer(&scan.timings_ms);
  Require(input.width * input.height == 0 ||
              static_cast<size_t>(input.width) * input.height == input.points.size(),
          "organised cloud of " + std::to_string(input.points.size()) + " points is not " +
              std::to_string(input.width) + "x" + std::to_string(input.height));

  // World frame, range, floor.
  std::vector<Eigen::Vector3f> in_range;
  in_range.reserve(input.points.size());
  const float max_range2 = static_cast<float>(options.max_range_m * options.max_range_m);
  for (const Eigen::Vector3f& p : input.points) {
    if (p.allFinite() && p.squaredNorm() > 0 && p.squaredNorm() <= max_range2)
      in_range.push_back(p);
  }
  scan.input_points = static_cast<int>(in_range.size());
  if (in_range.empty()) {  // a frame of nothing in range: nothing to detect, not an error
    scan.status = DetectionStatus::kNoPointsInRange;
    char message[96];
    std::snprintf(message,
                  sizeof(message),
                  "the scan has no finite point within %g m of the sensor",
                  options.max_range_m);
    scan.message = message;
    return scan;
  }
  if (input.world_from_camera) {
    scan.world_from_camera = *input.world_from_camera;
  } else {
    // The floor is found among all points up to 6 m (or the detection
    // range, when larger): in a real room seen level the floor within
    // detection range may be a sliver, the rest of it a little farther.
    constexpr float kFloorSearchRangeM = 6;
    const float floor_range = std::max(kFloorSearchRangeM, static_cast<float>(options.max_range_m));
    std::vector<Eigen::Vector3f> floor_points;
    floor_points.reserve(input.points.size());
    for (const Eigen::Vector3f& p : input.points) {
      if (p.allFinite() && p.squaredNorm() > 0 && p.squaredNorm() <= floor_range * floor_range)
        floor_points.push_back(p);
    }
    try {
      scan.world_from_camera = FindFloor(floor_points, options.floor);
    } catch (const InputError& error) {
      // Not the input's fault alone (the floor may be out of range or view):
      // a frame without detections, the reason in the message.
      scan.status = DetectionStatus::kNoFloor;
      scan.message = std::string(error.what()) +
                     "; give the pose (--world-from-camera, --floor-aligned) or raise --max-range";
      return scan;
    }
    scan.floor_estimated = true;
  }
  const Eigen::Matrix3f rotation = scan.world_from_camera.linear().cast<float>();
  const Eigen::Vector3f translation = scan.world_from_camera.translation().cast<float>();
  scan.sensor = translation;
  std::vector<Eigen::Vector3f> world, above_floor;
  world.reserve(in_range.size());
  for (const Eigen::Vector3f& p : in_range) {
    world.push_back(rotation * p + translation);
    if (world.back().z() >= options.floor_band_m) above_floor.push_back(world.back());
  }
  timer.Lap("floor");

  // Segments and features, exactly as in training.
  SegmentTimings segment_timings;
  scan.view = SegmentView(above_floor, scan.sensor, impl.model.options, &segment_timings);
  scan.timings_ms.emplace_back("preprocess", segment_timings.preprocess_ms);
  scan.timings_ms.emplace_back("segment", segment_timings.segment_ms);
  scan.timings_ms.emplace_back("features", segment_timings.features_ms);
  timer.Restart();  // the three stages above cover the time since the last lap
  scan.segment_of_point.assign(scan.view.cloud.size(), -1);
  for (size_t segment = 0; segment < scan.view.segments.size(); ++segment) {
    for (int point : scan.view.segments[segment])
      scan.segment_of_point[point] = static_cast<int>(segment);
  }

  // Walls: they neither vote nor count against a fit (a sideboard stands
  // against one).
  scan.structure = FindStructure(
      scan.view, options.max_segment_extent_m, impl.structure_height_m, &scan.structure_segment);
  // Render-and-compare needs the image: organised scans only.
  if (input.width * input.height > 0) {
    scan.intrinsics = IntrinsicsOfOrganisedCloud(input.points, input.width, input.height);
    if (scan.intrinsics) {
      scan.width = input.width;
      scan.height = input.height;
      scan.depth.assign(input.points.size(), std::numeric_limits<float>::quiet_NaN());
      for (size_t i = 0; i < input.points.size(); ++i) {
        const Eigen::Vector3f& p = input.points[i];
        if (p.allFinite() && p.z() > 0 && p.squaredNorm() <= max_range2) scan.depth[i] = p.z();
      }
    }
  }
  // Occupancy for verification, from every point in range (floor included).
  scan.occupancy.emplace(
      ThinOut(world, options.occupancy_voxel_m), scan.sensor, options.occupancy_voxel_m);
  timer.Lap("occupancy");
  return scan;
}

VoteMaps Detector::Vote(const PreparedScan& scan) const {
  const Impl& impl = *impl_;
  const DetectorOptions& options = impl.options;
  const TrainedModel& model = impl.model;
  const ViewSegments& view = scan.view;
  VoteMaps maps;
  maps.cell_m = options.cell_m;
  maps.grids.resize(kClasses);
  if (view.segments.empty()) return maps;
  // Per-class grids covering the scene plus a margin.
  Eigen::Vector2f low(1e9f, 1e9f), high(-1e9f, -1e9f);
  for (const Eigen::Vector3f& p : view.cloud.points) {
    low = low.cwiseMin(p.head<2>());
    high = high.cwiseMax(p.head<2>());
  }
  const float margin = 1.0f;
  maps.origin = low - Eigen::Vector2f::Constant(margin);
  maps.cols = std::min(
      2000, static_cast<int>(std::ceil((high.x() - low.x() + 2 * margin) / options.cell_m)));
  maps.rows = std::min(
      2000, static_cast<int>(std::ceil((high.y() - low.y() + 2 * margin) / options.cell_m)));
  // Each segment's votes on its own (both cores), then added up in segment
  // order: the same sums, in the same order, as one loop.
  std::vector<std::vector<HoughVote>> votes_of_segment(view.segments.size());
  ParallelFor(0, static_cast<int>(view.segments.size()), [&](int s) {
    if (scan.structure_segment[s]) return;
    const Eigen::Vector3f& centroid = view.centroids[s];
    // Relations were stored in the view-aligned frame: back to world.
    const Eigen::Matrix2f world_from_aligned =
        ViewAlignedFromWorld(scan.sensor, centroid).transpose();
    for (const WordActivation& activation :
         model.vocabulary.Activate(model.normalizer.Apply(view.features[s]))) {
      for (int e : impl.entries_of_word[activation.word]) {
        const ShapeEntry& entry = model.shape[e];
        if (options.vote_height_tolerance_m > 0 &&
            std::abs(entry.height - centroid.z()) > options.vote_height_tolerance_m) {
          continue;
        }
        const int class_index = static_cast<int>(entry.furniture_class);
        const Eigen::Vector2f at = centroid.head<2>() + world_from_aligned * entry.relation;
        const auto weight = static_cast<float>(
            activation.probability / impl.entries_per_class[activation.word][class_index]);
        votes_of_segment[s].push_back({s, class_index, at.x(), at.y(), weight});
      }
    }
  });
  std::vector<cv::Mat> grids(kClasses);
  for (cv::Mat& grid : grids) grid = cv::Mat::zeros(maps.rows, maps.cols, CV_32F);
  size_t total = 0;
  for (const auto& votes : votes_of_segment) total += votes.size();
  maps.votes.reserve(total);
  for (const auto& votes : votes_of_segment) {
    for (const HoughVote& vote : votes) {
      const int c = static_cast<int>(std::floor((vote.x - maps.origin.x()) / options.cell_m));
      const int r = static_cast<int>(std::floor((vote.y - maps.origin.y()) / options.cell_m));
      if (c < 0 || r < 0 || c >= maps.cols || r >= maps.rows) continue;
      grids[vote.class_index].at<float>(r, c) += vote.weight;
      maps.votes.push_back(vote);
    }
  }
  if (options.vote_sigma_m > 0) {
    const double sigma = options.vote_sigma_m / options.cell_m;
    for (cv::Mat& grid : grids) cv::GaussianBlur(grid, grid, cv::Size(0, 0), sigma, sigma);
  }
  for (int k = 0; k < kClasses; ++k)
    maps.grids[k].assign(grids[k].begin<float>(), grids[k].end<float>());
  return maps;
}

std::vector<DetectionDebug::Hypothesis> Detector::FindMaxima(
    const VoteMaps& votes, std::vector<DetectionDebug::VoteGrid>* grids, bool keep_values) const {
  const Impl& impl = *impl_;
  std::vector<DetectionDebug::Hypothesis> hypotheses;
  for (int k = 0; k < kClasses; ++k) {
    if (impl.class_width[k] <= 0 || votes.grids.size() <= static_cast<size_t>(k) ||
        votes.grids[k].empty()) {
      continue;
    }
    DetectionDebug::VoteGrid debug_grid;
    debug_grid.furniture_class = kAllClasses[k];
    debug_grid.origin = votes.origin;
    debug_grid.cell_m = votes.cell_m;
    debug_grid.cols = votes.cols;
    debug_grid.rows = votes.rows;
    // A view of the grid, not a copy (Maxima only reads it).
    const cv::Mat grid(votes.rows, votes.cols, CV_32F, const_cast<float*>(votes.grids[k].data()));
    for (auto& h : impl.Maxima(grid, k, votes.origin, &debug_grid)) hypotheses.push_back(h);
    if (grids != nullptr) {
      if (keep_values) debug_grid.values = votes.grids[k];
      grids->push_back(std::move(debug_grid));
    }
  }
  return hypotheses;
}

void Detector::RankCandidates(const PreparedScan& scan,
                              const VoteMaps& votes,
                              std::vector<DetectionDebug::Hypothesis>* hypotheses_out) const {
  const Impl& impl = *impl_;
  const DetectorOptions& options = impl.options;
  const ViewSegments& view = scan.view;
  std::vector<DetectionDebug::Hypothesis>& hypotheses = *hypotheses_out;
  // The segments behind each maximum; then each such segment's nearest
  // part subsets, once for all hypotheses.
  std::vector<std::vector<HoughVote>> votes_of_class(kClasses);
  for (const HoughVote& vote : votes.votes) votes_of_class[vote.class_index].push_back(vote);
  std::vector<std::map<int, double>> supports(hypotheses.size());
  ParallelFor(0, static_cast<int>(hypotheses.size()), [&](int h) {
    supports[h] = impl.Support(votes_of_class[static_cast<int>(hypotheses[h].furniture_class)],
                               &hypotheses[h]);
  });
  std::vector<char> needed(view.segments.size(), 0);
  for (const auto& support : supports) {
    for (const auto& [segment, weight] : support) needed[segment] = 1;
  }
  std::vector<int> queried;  // segments whose neighbours are needed
  for (size_t s = 0; s < view.segments.size(); ++s) {
    if (needed[s] && view.segments[s].size() >= 3) queried.push_back(static_cast<int>(s));
  }
  std::vector<VfhDescriptor> descriptors(queried.size());
  ParallelFor(0, static_cast<int>(queried.size()), [&](int q) {
    descriptors[q] = ComputeVfh(view.cloud,
                                view.segments[queried[q]],
                                scan.sensor,
                                impl.model.options.part_subsets.vfh_size_component);
  });
  std::vector<std::vector<int>> nearest = impl.parts->NearestMany(descriptors, options.neighbours);
  std::vector<std::vector<int>> segment_neighbours(view.segments.size());
  for (size_t q = 0; q < queried.size(); ++q)
    segment_neighbours[queried[q]] = std::move(nearest[q]);
  for (size_t h = 0; h < hypotheses.size(); ++h)
    impl.Rank(supports[h], segment_neighbours, &hypotheses[h]);
  // Maxima of one class backed by (almost) the same segments would give the
  // same fit: only the strongest is fitted (hypotheses are strongest first
  // within a class).
  for (size_t h = 0; h < hypotheses.size(); ++h) {
    for (size_t k = 0; k < h; ++k) {
      if (hypotheses[k].furniture_class != hypotheses[h].furniture_class ||
          hypotheses[k].candidate_models.empty()) {
        continue;
      }
      const std::vector<int>& a = hypotheses[k].segments;
      const std::vector<int>& b = hypotheses[h].segments;
      std::vector<int> common;
      std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(common));
      if (common.size() >= kSameSupport * std::max(a.size(), b.size())) {
        hypotheses[h].candidate_models.clear();
        hypotheses[h].outcome = HypothesisOutcome::kSameSupport;
        break;
      }
    }
  }
}

std::vector<FittedHypothesis> Detector::FitAndScore(
    const PreparedScan& scan, std::vector<DetectionDebug::Hypothesis>* hypotheses) const {
  std::vector<FittedHypothesis> fits(hypotheses->size());
  ParallelFor(0, static_cast<int>(hypotheses->size()), [&](int h) {
    impl_->FitAndVerify(scan, h, &(*hypotheses)[h], &fits[h]);
  });
  return fits;
}

std::vector<int> Detector::Suppress(const PreparedScan& scan,
                                    const std::vector<FittedHypothesis>& fits,
                                    std::vector<DetectionDebug::Hypothesis>* hypotheses) const {
  const DetectorOptions& options = impl_->options;
  const TrainedModel& model = impl_->model;
  // Best score first: a detection is dropped when kept ones already explain
  // more than max_shared_support of the points it explains, or when its
  // footprint overlaps a kept one's by more than max_footprint_overlap (of
  // the smaller footprint).
  std::vector<int> order;
  for (size_t h = 0; h < fits.size(); ++h) {
    if (fits[h].detection) order.push_back(static_cast<int>(h));
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return fits[a].detection->score > fits[b].detection->score;
  });
  std::vector<int> kept;
  std::vector<char> explained(scan.view.cloud.size(), 0);
  for (int h : order) {
    const Detection& d = *fits[h].detection;
    const std::vector<int>& support = fits[h].support;
    size_t shared = 0;
    for (int i : support) shared += explained[i];
    const double shared_fraction =
        support.empty() ? 1.0 : static_cast<double>(shared) / support.size();
    const cv::RotatedRect footprint =
        Footprint(model.model_shapes[d.model_index], PlanarPose{d.x, d.y, d.yaw});
    double overlap = 0;
    for (int k : kept) {
      const Detection& other = *fits[k].detection;
      overlap = std::max(overlap,
                         FootprintOverlap(footprint,
                                          Footprint(model.model_shapes[other.model_index],
                                                    PlanarPose{other.x, other.y, other.yaw})));
    }
    if (shared_fraction > options.max_shared_support || overlap > options.max_footprint_overlap) {
      (*hypotheses)[h].outcome = HypothesisOutcome::kSuppressed;
      (*hypotheses)[h].outcome_values[0] = shared_fraction;
      (*hypotheses)[h].outcome_values[1] = overlap;
      continue;
    }
    for (int i : support) explained[i] = 1;
    kept.push_back(h);
  }
  return kept;
}

DetectionResult Detector::Detect(const DetectionInput& input, bool keep_debug) const {
  DetectionResult result;
  StageTimer timer(&result.timings_ms);
  PreparedScan scan = Prepare(input);
  result.input_points = scan.input_points;
  if (scan.status != DetectionStatus::kDetected) {
    result.status = scan.status;
    result.message = scan.message;
    timer.Total();
    return result;
  }
  result.world_from_camera = scan.world_from_camera;
  result.floor_estimated = scan.floor_estimated;
  result.points = static_cast<int>(scan.view.cloud.size());
  result.segments = static_cast<int>(scan.view.segments.size());
  for (const auto& stage : scan.timings_ms) result.timings_ms.push_back(stage);
  timer.Restart();

  const VoteMaps votes = Vote(scan);
  timer.Lap("vote");
  std::vector<DetectionDebug::Hypothesis> hypotheses =
      FindMaxima(votes, keep_debug ? &result.debug.grids : nullptr, keep_debug);
  timer.Lap("maxima");
  RankCandidates(scan, votes, &hypotheses);
  timer.Lap("rank");
  std::vector<FittedHypothesis> fits = FitAndScore(scan, &hypotheses);
  timer.Lap("fit+verify");
  const std::vector<int> kept = Suppress(scan, fits, &hypotheses);
  for (int h : kept) result.detections.push_back(*fits[h].detection);
  timer.Lap("suppress");
  timer.Total();
  result.debug.hypotheses = std::move(hypotheses);  // small: kept for evaluation (protocol A) too

  if (keep_debug) {
    DetectionDebug& debug = result.debug;
    const ViewSegments& view = scan.view;
    debug.points = view.cloud.points;
    debug.segment_of_point.assign(view.cloud.size(), -1);
    for (size_t s = 0; s < view.segments.size(); ++s) {
      for (int i : view.segments[s]) debug.segment_of_point[i] = static_cast<int>(s);
    }
    for (int h : kept) debug.fitted_points.push_back(std::move(fits[h].fitted_points));
  }
  return result;
}

}  // namespace furn
