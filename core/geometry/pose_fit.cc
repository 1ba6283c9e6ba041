#include "core/geometry/pose_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "core/util/error.h"
#include "core/util/random.h"

namespace furn {

Eigen::Vector3f PlanarPose::Apply(const Eigen::Vector3f& m) const {
  const float c = static_cast<float>(std::cos(yaw)), s = static_cast<float>(std::sin(yaw));
  return Eigen::Vector3f(c * m.x() - s * m.y() + static_cast<float>(x),
                         s * m.x() + c * m.y() + static_cast<float>(y),
                         m.z());
}

Eigen::Vector3f PlanarPose::Inverse(const Eigen::Vector3f& p) const {
  const float c = static_cast<float>(std::cos(yaw)), s = static_cast<float>(std::sin(yaw));
  const float dx = p.x() - static_cast<float>(x), dy = p.y() - static_cast<float>(y);
  return Eigen::Vector3f(c * dx + s * dy, -s * dx + c * dy, p.z());
}

PlanarTransform::PlanarTransform(const PlanarPose& pose)
    : c_(static_cast<float>(std::cos(pose.yaw))),
      s_(static_cast<float>(std::sin(pose.yaw))),
      x_(static_cast<float>(pose.x)),
      y_(static_cast<float>(pose.y)) {}

PlanarPose PoseFromPair(const Eigen::Vector3f& scene, const Eigen::Vector3f& model, double yaw) {
  PlanarPose pose;
  pose.yaw = WrapAngle(yaw);
  const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
  pose.x = scene.x() - (c * model.x() - s * model.y());  // t = s - R m
  pose.y = scene.y() - (s * model.x() + c * model.y());
  return pose;
}

void FitOptions::Check() const {
  // Upper bounds: the work of a fit scales with them (an options file from
  // someone else could ask for days).
  Require(iterations >= 1 && iterations <= kMaxFitIterations,
          "fit iterations " + std::to_string(iterations) + " must be in 1.." +
              std::to_string(kMaxFitIterations));
  Require(height_tolerance_m > 0 && height_tolerance_m < 1,
          "fit height tolerance must be in (0, 1) m");
  Require(inlier_m > 0 && inlier_m < 1, "fit inlier distance must be in (0, 1) m");
  Require(max_offset_m > 0, "fit max offset must be > 0");
  Require(refine_iterations >= 0 && refine_iterations <= 100,
          "fit refine iterations " + std::to_string(refine_iterations) + " must be in 0..100");
  Require(above_m >= 0 && above_m <= 2, "fit above_m must be in 0..2 m");
}

struct ModelFitter::Impl {
  // Voxels (inlier_m / 2) within inlier_m of a model point hold the index of
  // the model point nearest their centre (-1 elsewhere): O(1) coverage tests
  // and ICP correspondences.
  float cell = 0, inverse_cell = 0;
  Eigen::Vector3f origin;
  Eigen::Vector3i size;
  std::vector<int32_t> nearest;
  // Model point indices by height bucket (height_tolerance_m).
  int first_bucket = 0;
  std::vector<std::vector<int>> by_height;
  std::once_flag built;

  int NearestTo(const Eigen::Vector3f& q) const {
    Eigen::Vector3i c;
    for (int axis = 0; axis < 3; ++axis) {
      const float f = (q[axis] - origin[axis]) * inverse_cell;
      if (!(f >= 0 && f < size[axis])) return -1;
      c[axis] = static_cast<int>(f);  // f >= 0: truncation is floor
    }
    return nearest[(static_cast<size_t>(c.z()) * size.y() + c.y()) * size.x() + c.x()];
  }
  bool Near(const Eigen::Vector3f& q) const { return NearestTo(q) >= 0; }
};

ModelFitter::ModelFitter(const ModelShape& shape, const FitOptions& options)
    : shape_(&shape), options_(options), impl_(std::make_unique<Impl>()) {
  options.Check();
  Require(!shape.points.empty(), "model shape has no points to fit");
}

// The grid and buckets are built at the first fit of the model: a detector
// loads quickly, and a scan pays only for the models it fits.
const ModelFitter::Impl& ModelFitter::Built() const {
  std::call_once(impl_->built, [this] { Build(); });
  return *impl_;
}

void ModelFitter::Build() const {
  const ModelShape& shape = *shape_;
  const FitOptions& options = options_;
  Impl& impl = *impl_;
  const float inlier = static_cast<float>(options.inlier_m);
  impl.cell = inlier / 2;
  impl.inverse_cell = 1 / impl.cell;
  impl.origin = shape.low - Eigen::Vector3f::Constant(inlier + impl.cell);
  const Eigen::Vector3f extent =
      shape.high - impl.origin + Eigen::Vector3f::Constant(inlier + impl.cell);
  for (int axis = 0; axis < 3; ++axis)
    impl.size[axis] = static_cast<int>(std::ceil(extent[axis] / impl.cell)) + 1;
  const size_t cells = static_cast<size_t>(impl.size.prod());
  impl.nearest.assign(cells, -1);
  std::vector<float> best(cells, std::numeric_limits<float>::max());  // squared, in cells
  const int reach = static_cast<int>(std::ceil(inlier / impl.cell));
  const float limit = (inlier / impl.cell + 0.5f) * (inlier / impl.cell + 0.5f);
  for (size_t i = 0; i < shape.points.size(); ++i) {
    const Eigen::Vector3f local = (shape.points[i] - impl.origin) / impl.cell;
    const Eigen::Vector3i centre = local.array().floor().cast<int>();
    for (int dz = -reach; dz <= reach; ++dz) {
      for (int dy = -reach; dy <= reach; ++dy) {
        for (int dx = -reach; dx <= reach; ++dx) {
          const Eigen::Vector3i c = centre + Eigen::Vector3i(dx, dy, dz);
          if ((c.array() < 0).any() || (c.array() >= impl.size.array()).any()) continue;
          // Within inlier_m of the voxel's centre, plus half a voxel of slack.
          const float d2 = ((c.cast<float>().array() + 0.5f).matrix() - local).squaredNorm();
          const size_t k =
              (static_cast<size_t>(c.z()) * impl.size.y() + c.y()) * impl.size.x() + c.x();
          if (d2 > limit || d2 >= best[k]) continue;
          best[k] = d2;
          impl.nearest[k] = static_cast<int32_t>(i);
        }
      }
    }
  }
  const double tolerance = options.height_tolerance_m;
  impl.first_bucket = static_cast<int>(std::floor(shape.low.z() / tolerance));
  const int last_bucket = static_cast<int>(std::floor(shape.high.z() / tolerance));
  impl.by_height.resize(last_bucket - impl.first_bucket + 1);
  for (size_t i = 0; i < shape.points.size(); ++i) {
    const int bucket = static_cast<int>(std::floor(shape.points[i].z() / tolerance));
    impl.by_height[bucket - impl.first_bucket].push_back(static_cast<int>(i));
  }
}

ModelFitter::~ModelFitter() = default;
ModelFitter::ModelFitter(ModelFitter&&) noexcept = default;

int ModelFitter::Covered(const std::vector<Eigen::Vector3f>& scene_points,
                         const PlanarPose& pose,
                         int* inside) const {
  const Impl& impl = Built();
  const PlanarTransform transform(pose);
  const Eigen::Vector3f margin = Eigen::Vector3f::Constant(static_cast<float>(options_.inlier_m));
  const Eigen::Vector3f low = shape_->low - margin;
  // Points just above the model count too: a column taller than a sideboard
  // is not explained by the sideboard.
  const Eigen::Vector3f high =
      shape_->high + margin + Eigen::Vector3f(0, 0, static_cast<float>(options_.above_m));
  int covered = 0, in_box = 0;
  for (const Eigen::Vector3f& p : scene_points) {
    const Eigen::Vector3f q = transform.Inverse(p);
    covered += impl.Near(q);
    if (inside != nullptr)
      in_box += (q.array() >= low.array()).all() && (q.array() <= high.array()).all();
  }
  if (inside != nullptr) *inside = in_box;
  return covered;
}

int ModelFitter::CoveredAtLeast(const std::vector<Eigen::Vector3f>& scene_points,
                                const PlanarPose& pose,
                                int needed) const {
  const Impl& impl = Built();
  const PlanarTransform transform(pose);
  const int n = static_cast<int>(scene_points.size());
  int covered = 0;
  for (int i = 0; i < n; ++i) {
    covered += impl.Near(transform.Inverse(scene_points[i]));
    if (covered + (n - 1 - i) < needed) return -1;  // cannot reach it any more
  }
  return covered;
}

std::vector<int> ModelFitter::CoveredIndices(const std::vector<Eigen::Vector3f>& scene_points,
                                             const PlanarPose& pose) const {
  const Impl& impl = Built();
  const PlanarTransform transform(pose);
  std::vector<int> covered;
  for (size_t i = 0; i < scene_points.size(); ++i) {
    if (impl.Near(transform.Inverse(scene_points[i]))) covered.push_back(static_cast<int>(i));
  }
  return covered;
}

namespace {

constexpr size_t kScoringPoints = 150;  // points a candidate pose is scored on
constexpr int kHintYaws = 24;           // yaws tried at the hint (every 15 degrees)
constexpr size_t kRefined = 4;          // best candidates refined by ICP
constexpr double kTwoPointShare = 0.5;  // draws of two point pairs (the rest: one, with normals)

// Horizontal azimuth of a normal, or NaN when it is near vertical.
double Azimuth(const Eigen::Vector3f& normal) {
  const float horizontal = normal.head<2>().norm();
  return horizontal < 0.3f ? std::nan("") : std::atan2(normal.y(), normal.x());
}

}  // namespace

PoseFit ModelFitter::Refine(const std::vector<Eigen::Vector3f>& scene_points,
                            const PlanarPose& start) const {
  const Impl& impl = Built();
  const ModelShape& shape = *shape_;
  PoseFit best;
  best.scene_points = static_cast<int>(scene_points.size());
  best.found = true;
  best.pose = start;
  best.covered = Covered(scene_points, start, &best.inside);
  // ICP over (x, y, yaw): the model point nearest each covered scene point
  // (from the grid), then the closed-form 2D rigid alignment of the pairs.
  for (int it = 0; it < options_.refine_iterations; ++it) {
    Eigen::Vector2d model_mean = Eigen::Vector2d::Zero(), scene_mean = Eigen::Vector2d::Zero();
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> pairs;
    const PlanarTransform transform(best.pose);
    for (const Eigen::Vector3f& p : scene_points) {
      const int nearest = impl.NearestTo(transform.Inverse(p));
      if (nearest < 0) continue;
      const Eigen::Vector2d m = shape.points[nearest].head<2>().cast<double>();
      const Eigen::Vector2d s = p.head<2>().cast<double>();
      pairs.emplace_back(m, s);
      model_mean += m;
      scene_mean += s;
    }
    if (pairs.size() < 3) break;
    model_mean /= pairs.size();
    scene_mean /= pairs.size();
    double dot = 0, cross = 0;
    for (const auto& [m, s] : pairs) {
      const Eigen::Vector2d a = m - model_mean, b = s - scene_mean;
      dot += a.dot(b);
      cross += a.x() * b.y() - a.y() * b.x();
    }
    PlanarPose refined;
    refined.yaw = WrapAngle(std::atan2(cross, dot));
    const double c = std::cos(refined.yaw), sn = std::sin(refined.yaw);
    refined.x = scene_mean.x() - (c * model_mean.x() - sn * model_mean.y());
    refined.y = scene_mean.y() - (sn * model_mean.x() + c * model_mean.y());
    int inside = 0;
    const int covered = Covered(scene_points, refined, &inside);
    if (covered < best.covered) break;
    const bool converged =
        std::abs(refined.x - best.pose.x) < 1e-4 && std::abs(refined.y - best.pose.y) < 1e-4;
    best.pose = refined;
    best.covered = covered;
    best.inside = inside;
    if (converged) break;
  }
  return best;
}

namespace {

// One fit's RANSAC search (SPEC §8.5): candidate poses from draws, each
// scored on an even subsample of the scene; the best kRefined kept, by
// subsample coverage, then draw order. The draws take the generator in a
// fixed order: the same seed gives the same candidates.
class PoseSearch {
 public:
  PoseSearch(const ModelFitter& fitter,
             const FitOptions& options,
             const std::vector<std::vector<int>>& model_by_height,
             int first_bucket,
             const std::vector<Eigen::Vector3f>& scene_points,
             const std::vector<Eigen::Vector3f>& scene_normals,
             const Eigen::Vector2f& hint,
             uint64_t seed)
      : fitter_(fitter),
        shape_(fitter.shape()),
        options_(options),
        by_height_(model_by_height),
        first_bucket_(first_bucket),
        points_(scene_points),
        normals_(scene_normals),
        hint_(hint),
        rng_(seed) {
    const size_t stride = std::max<size_t>(1, points_.size() / kScoringPoints);
    for (size_t i = 0; i < points_.size(); i += stride) scoring_.push_back(points_[i]);
    // Points with a horizontal normal fix the yaw; those with a vertical one
    // only give a random guess, so most draws take the former.
    for (size_t i = 0; i < points_.size(); ++i) {
      if (!std::isnan(Azimuth(normals_[i]))) oriented_.push_back(i);
    }
    // Scene points by height bucket, for the two-point draws.
    scene_by_height_.resize(by_height_.size() + 2);
    for (size_t i = 0; i < points_.size(); ++i) {
      const int b =
          static_cast<int>(std::floor(points_[i].z() / tolerance())) - scene_first_bucket();
      if (b >= 0 && b < static_cast<int>(scene_by_height_.size()))
        scene_by_height_[b].push_back(static_cast<int>(i));
    }
  }

  // The hint itself at every yaw step (tables and other shapes whose normals
  // say little about their yaw are found from these), then the draws.
  const std::vector<std::pair<int, PlanarPose>>& Run() {
    for (int k = 0; k < kHintYaws; ++k)
      Consider(PlanarPose{hint_.x(), hint_.y(), 2 * M_PI * k / kHintYaws});
    for (int it = 0; it < options_.iterations; ++it) {
      if (rng_.Bernoulli(kTwoPointShare)) {
        TwoPointDraw();
      } else {
        OnePointDraw();
      }
    }
    return candidates_;
  }

 private:
  double tolerance() const { return options_.height_tolerance_m; }
  int scene_first_bucket() const { return first_bucket_ - 1; }

  // A candidate that cannot beat the last of the kept ones stops being
  // counted early.
  void Consider(const PlanarPose& pose) {
    if (Eigen::Vector2f(pose.x - hint_.x(), pose.y - hint_.y()).norm() > options_.max_offset_m)
      return;
    const int needed = candidates_.size() < kRefined ? 0 : candidates_.back().first + 1;
    const int covered = fitter_.CoveredAtLeast(scoring_, pose, needed);
    if (covered < needed) return;
    auto at = std::upper_bound(
        candidates_.begin(), candidates_.end(), covered, [](int value, const auto& c) {
          return value > c.first;
        });
    candidates_.insert(at, {covered, pose});
    if (candidates_.size() > kRefined) candidates_.pop_back();
  }

  // A model point at height `z` that `accept`s: a random one of its height
  // bucket's and the neighbours' points, retried up to `tries` times; or -1.
  template <typename Accept>
  int ModelPointAt(float z, int tries, const Accept& accept) {
    const int bucket = static_cast<int>(std::floor(z / tolerance())) - first_bucket_;
    for (int attempt = 0; attempt < tries; ++attempt) {
      const int b = bucket + static_cast<int>(rng_.UniformInt(-1, 1));
      if (b < 0 || b >= static_cast<int>(by_height_.size()) || by_height_[b].empty()) continue;
      const int candidate = by_height_[b][rng_.UniformInt(0, by_height_[b].size() - 1)];
      if (std::abs(shape_.points[candidate].z() - z) <= tolerance() && accept(candidate))
        return candidate;
    }
    return -1;
  }

  // Two scene points at one height and two model points as far apart: the
  // yaw from the directions between them, whatever the normals.
  void TwoPointDraw() {
    const float model_span = (shape_.high - shape_.low).head<2>().norm();
    const float min_pair = static_cast<float>(4 * options_.inlier_m);
    const int i = static_cast<int>(rng_.UniformInt(0, points_.size() - 1));
    const Eigen::Vector3f& s1 = points_[i];
    const int sb = static_cast<int>(std::floor(s1.z() / tolerance())) - scene_first_bucket();
    if (sb < 0 || sb >= static_cast<int>(scene_by_height_.size())) return;
    const std::vector<int>& level = scene_by_height_[sb];
    const Eigen::Vector3f& s2 = points_[level[rng_.UniformInt(0, level.size() - 1)]];
    const float distance = (s2 - s1).head<2>().norm();
    if (distance < min_pair || distance > model_span) return;
    const int m1 = ModelPointAt(s1.z(), 4, [](int) { return true; });
    if (m1 < 0) return;
    const int m2 = ModelPointAt(s2.z(), 12, [&](int m) {
      return std::abs((shape_.points[m] - shape_.points[m1]).head<2>().norm() - distance) <=
             options_.inlier_m;
    });
    if (m2 < 0) return;
    const Eigen::Vector3f sd = s2 - s1, md = shape_.points[m2] - shape_.points[m1];
    const double yaw = std::atan2(sd.y(), sd.x()) - std::atan2(md.y(), md.x());
    Consider(PoseFromPair((s1 + s2) / 2, (shape_.points[m1] + shape_.points[m2]) / 2, yaw));
  }

  // One scene point and a model point at its height: the yaw from their
  // normals' azimuths (random when either is near vertical).
  void OnePointDraw() {
    const size_t i = !oriented_.empty() && rng_.Bernoulli(0.8)
                         ? oriented_[rng_.UniformInt(0, oriented_.size() - 1)]
                         : static_cast<size_t>(rng_.UniformInt(0, points_.size() - 1));
    const Eigen::Vector3f& s = points_[i];
    const int model_index = ModelPointAt(s.z(), 4, [](int) { return true; });
    if (model_index < 0) return;
    const double scene_azimuth = Azimuth(normals_[i]);
    const double model_azimuth = Azimuth(shape_.normals[model_index]);
    const double yaw = std::isnan(scene_azimuth) || std::isnan(model_azimuth)
                           ? rng_.Uniform(0, 2 * M_PI)
                           : scene_azimuth - model_azimuth;
    Consider(PoseFromPair(s, shape_.points[model_index], yaw));
  }

  const ModelFitter& fitter_;
  const ModelShape& shape_;
  const FitOptions& options_;
  const std::vector<std::vector<int>>& by_height_;
  const int first_bucket_;
  const std::vector<Eigen::Vector3f>& points_;
  const std::vector<Eigen::Vector3f>& normals_;
  const Eigen::Vector2f hint_;
  Rng rng_;
  std::vector<Eigen::Vector3f> scoring_;
  std::vector<size_t> oriented_;
  std::vector<std::vector<int>> scene_by_height_;
  std::vector<std::pair<int, PlanarPose>> candidates_;
};

}  // namespace

PoseFit ModelFitter::Fit(const std::vector<Eigen::Vector3f>& scene_points,
                         const std::vector<Eigen::Vector3f>& scene_normals,
                         const Eigen::Vector2f& hint,
                         uint64_t seed) const {
  Require(scene_points.size() == scene_normals.size(), "fit: one normal per scene point");
  PoseFit none;
  none.scene_points = static_cast<int>(scene_points.size());
  if (scene_points.empty()) return none;
  const Impl& impl = Built();
  PoseSearch search(
      *this, options_, impl.by_height, impl.first_bucket, scene_points, scene_normals, hint, seed);
  const std::vector<std::pair<int, PlanarPose>>& candidates = search.Run();
  if (candidates.empty()) return none;
  // The best few refined by ICP.
  PoseFit best = none;
  for (size_t k = 0; k < std::min<size_t>(kRefined, candidates.size()); ++k) {
    const PoseFit refined = Refine(scene_points, candidates[k].second);
    if (!best.found || refined.covered > best.covered) best = refined;
  }
  return best;
}

}  // namespace furn
