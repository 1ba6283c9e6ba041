#include "core/pose_fit.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>

#include "core/error.h"
#include "core/pcl_conversion.h"
#include "core/random.h"

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

double WrapAngle(double radians) {
  double wrapped = std::fmod(radians, 2 * M_PI);
  if (wrapped < 0) wrapped += 2 * M_PI;
  return wrapped >= 2 * M_PI ? 0.0 : wrapped;
}

PlanarPose PoseFromPair(const Eigen::Vector3f& scene, const Eigen::Vector3f& model, double yaw) {
  PlanarPose pose;
  pose.yaw = WrapAngle(yaw);
  const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
  pose.x = scene.x() - (c * model.x() - s * model.y());  // t = s - R m
  pose.y = scene.y() - (s * model.x() + c * model.y());
  return pose;
}

void FitOptions::Check() const {
  Require(iterations >= 1, "fit iterations must be >= 1");
  Require(height_tolerance_m > 0 && height_tolerance_m < 1,
          "fit height tolerance must be in (0, 1) m");
  Require(inlier_m > 0 && inlier_m < 1, "fit inlier distance must be in (0, 1) m");
  Require(max_offset_m > 0, "fit max offset must be > 0");
  Require(refine_iterations >= 0, "fit refine iterations must be >= 0");
}

struct ModelFitter::Impl {
  // Voxels (inlier_m / 2) within inlier_m of a model point: O(1) coverage tests.
  float cell = 0;
  Eigen::Vector3f origin;
  Eigen::Vector3i size;
  std::vector<uint8_t> near;
  // Model point indices by height bucket (height_tolerance_m).
  int first_bucket = 0;
  std::vector<std::vector<int>> by_height;
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;

  bool Near(const Eigen::Vector3f& q) const {
    Eigen::Vector3i c;
    for (int axis = 0; axis < 3; ++axis) {
      const float f = std::floor((q[axis] - origin[axis]) / cell);
      if (!(f >= 0 && f < size[axis])) return false;
      c[axis] = static_cast<int>(f);
    }
    return near[(static_cast<size_t>(c.z()) * size.y() + c.y()) * size.x() + c.x()] != 0;
  }
};

ModelFitter::ModelFitter(const ModelShape& shape, const FitOptions& options)
    : shape_(&shape), options_(options), impl_(std::make_unique<Impl>()) {
  options.Check();
  Require(!shape.points.empty(), "model shape has no points to fit");
  Impl& impl = *impl_;
  const float inlier = static_cast<float>(options.inlier_m);
  impl.cell = inlier / 2;
  impl.origin = shape.low - Eigen::Vector3f::Constant(inlier + impl.cell);
  const Eigen::Vector3f extent =
      shape.high - impl.origin + Eigen::Vector3f::Constant(inlier + impl.cell);
  for (int axis = 0; axis < 3; ++axis)
    impl.size[axis] = static_cast<int>(std::ceil(extent[axis] / impl.cell)) + 1;
  impl.near.assign(static_cast<size_t>(impl.size.prod()), 0);
  const int reach = static_cast<int>(std::ceil(inlier / impl.cell)) + 1;
  for (const Eigen::Vector3f& p : shape.points) {
    const Eigen::Vector3f local = (p - impl.origin) / impl.cell;
    const Eigen::Vector3i centre = local.array().floor().cast<int>();
    for (int dz = -reach; dz <= reach; ++dz) {
      for (int dy = -reach; dy <= reach; ++dy) {
        for (int dx = -reach; dx <= reach; ++dx) {
          const Eigen::Vector3i c = centre + Eigen::Vector3i(dx, dy, dz);
          if ((c.array() < 0).any() || (c.array() >= impl.size.array()).any()) continue;
          // Distance from the point to the voxel's centre, less half its diagonal.
          const Eigen::Vector3f centre_of_cell = (c.cast<float>().array() + 0.5f).matrix();
          if ((centre_of_cell - local).norm() * impl.cell > inlier + 0.5f * impl.cell) continue;
          impl.near[(static_cast<size_t>(c.z()) * impl.size.y() + c.y()) * impl.size.x() + c.x()] =
              1;
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
  impl.tree.setInputCloud(ToPclPoints(shape.points));
}

ModelFitter::~ModelFitter() = default;
ModelFitter::ModelFitter(ModelFitter&&) noexcept = default;

int ModelFitter::Covered(const std::vector<Eigen::Vector3f>& scene_points,
                         const PlanarPose& pose,
                         int* inside) const {
  const float c = static_cast<float>(std::cos(pose.yaw)),
              s = static_cast<float>(std::sin(pose.yaw));
  const float x = static_cast<float>(pose.x), y = static_cast<float>(pose.y);
  const Eigen::Vector3f margin = Eigen::Vector3f::Constant(static_cast<float>(options_.inlier_m));
  const Eigen::Vector3f low = shape_->low - margin, high = shape_->high + margin;
  int covered = 0, in_box = 0;
  for (const Eigen::Vector3f& p : scene_points) {
    const float dx = p.x() - x, dy = p.y() - y;  // PlanarPose::Inverse, sin and cos hoisted
    const Eigen::Vector3f q(c * dx + s * dy, -s * dx + c * dy, p.z());
    covered += impl_->Near(q);
    if (inside != nullptr)
      in_box += (q.array() >= low.array()).all() && (q.array() <= high.array()).all();
  }
  if (inside != nullptr) *inside = in_box;
  return covered;
}

std::vector<int> ModelFitter::CoveredIndices(const std::vector<Eigen::Vector3f>& scene_points,
                                             const PlanarPose& pose) const {
  std::vector<int> covered;
  for (size_t i = 0; i < scene_points.size(); ++i) {
    if (impl_->Near(pose.Inverse(scene_points[i]))) covered.push_back(static_cast<int>(i));
  }
  return covered;
}

namespace {

constexpr size_t kScoringPoints = 200;

// Horizontal azimuth of a normal, or NaN when it is near vertical.
double Azimuth(const Eigen::Vector3f& normal) {
  const float horizontal = normal.head<2>().norm();
  return horizontal < 0.3f ? std::nan("") : std::atan2(normal.y(), normal.x());
}

}  // namespace

PoseFit ModelFitter::Fit(const std::vector<Eigen::Vector3f>& scene_points,
                         const std::vector<Eigen::Vector3f>& scene_normals,
                         const Eigen::Vector2f& hint,
                         uint64_t seed) const {
  Require(scene_points.size() == scene_normals.size(), "fit: one normal per scene point");
  PoseFit best;
  best.scene_points = static_cast<int>(scene_points.size());
  if (scene_points.empty()) return best;
  const Impl& impl = *impl_;
  const ModelShape& shape = *shape_;
  const double tolerance = options_.height_tolerance_m;
  Rng rng(seed);
  // Draws are scored on an even subsample; the best pose is then rescored
  // and refined on every point.
  std::vector<Eigen::Vector3f> scoring;
  const size_t stride = std::max<size_t>(1, scene_points.size() / kScoringPoints);
  for (size_t i = 0; i < scene_points.size(); i += stride) scoring.push_back(scene_points[i]);
  for (int it = 0; it < options_.iterations; ++it) {
    const size_t i = static_cast<size_t>(rng.UniformInt(0, scene_points.size() - 1));
    const Eigen::Vector3f& s = scene_points[i];
    const int bucket = static_cast<int>(std::floor(s.z() / tolerance)) - impl.first_bucket;
    // A model point at the same height: a random one of the bucket's and its
    // neighbours' points, retried when it is out of tolerance.
    int model_index = -1;
    for (int attempt = 0; attempt < 4 && model_index < 0; ++attempt) {
      const int b = bucket + static_cast<int>(rng.UniformInt(-1, 1));
      if (b < 0 || b >= static_cast<int>(impl.by_height.size()) || impl.by_height[b].empty())
        continue;
      const int candidate = impl.by_height[b][rng.UniformInt(0, impl.by_height[b].size() - 1)];
      if (std::abs(shape.points[candidate].z() - s.z()) <= tolerance) model_index = candidate;
    }
    if (model_index < 0) continue;
    const double scene_azimuth = Azimuth(scene_normals[i]);
    const double model_azimuth = Azimuth(shape.normals[model_index]);
    const double yaw = std::isnan(scene_azimuth) || std::isnan(model_azimuth)
                           ? rng.Uniform(0, 2 * M_PI)
                           : scene_azimuth - model_azimuth;
    const PlanarPose pose = PoseFromPair(s, shape.points[model_index], yaw);
    if (Eigen::Vector2f(pose.x - hint.x(), pose.y - hint.y()).norm() > options_.max_offset_m)
      continue;
    const int covered = Covered(scoring, pose);
    if (!best.found || covered > best.covered) {
      best.pose = pose;
      best.covered = covered;
      best.found = true;
    }
  }
  if (!best.found) return best;
  best.covered = Covered(scene_points, best.pose, &best.inside);

  // ICP over (x, y, yaw): nearest model point of every covered scene point,
  // then the closed-form 2D rigid alignment of the pairs.
  std::vector<int> nearest(1);
  std::vector<float> distance(1);
  const float max_pair = static_cast<float>(2 * options_.inlier_m);
  for (int it = 0; it < options_.refine_iterations; ++it) {
    Eigen::Vector2d model_mean = Eigen::Vector2d::Zero(), scene_mean = Eigen::Vector2d::Zero();
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> pairs;
    for (const Eigen::Vector3f& p : scene_points) {
      const Eigen::Vector3f q = best.pose.Inverse(p);
      if (impl.tree.nearestKSearch(pcl::PointXYZ(q.x(), q.y(), q.z()), 1, nearest, distance) < 1 ||
          distance[0] > max_pair * max_pair) {
        continue;
      }
      const Eigen::Vector2d m = shape.points[nearest[0]].head<2>().cast<double>();
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

}  // namespace furn
