#include "core/codebook/sgf.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/geometry/neighbour_grid.h"
#include "core/geometry/voxel_key.h"
#include "core/util/error.h"

namespace furn {
namespace {

double SafeRatio(double numerator, double denominator) {
  return denominator > 1e-15 ? numerator / denominator : 0.0;
}

// Fraction of boundary points, by PCL's angle criterion (BoundaryEstimation):
// the segment's neighbours of a point, projected on its tangent plane, leave
// an angular gap larger than the threshold. Written on the neighbour grid:
// PCL's kd-tree version was the slowest part of detection.
double BoundaryProportion(const PointCloud& cloud,
                          const std::vector<int>& segment,
                          const SgfOptions& options) {
  std::vector<Eigen::Vector3f> points;
  points.reserve(segment.size());
  for (int i : segment) points.push_back(cloud.points[i]);
  const float radius = static_cast<float>(options.boundary_radius_m);
  const NeighbourGrid grid(points, radius);
  const double threshold = options.boundary_angle_deg * M_PI / 180;
  std::vector<double> angles;
  size_t count = 0, tested = 0;
  // A proportion: estimated on at most kBoundarySamples evenly spread points
  // (walls have tens of thousands).
  constexpr size_t kBoundarySamples = 1500;
  const size_t stride = (points.size() + kBoundarySamples - 1) / kBoundarySamples;
  for (size_t k = 0; k < points.size(); k += stride) {
    ++tested;
    const Eigen::Vector3f& normal = cloud.normals[segment[k]];
    // A tangent basis: u perpendicular to the normal, v = n x u.
    Eigen::Vector3f u = normal.unitOrthogonal();
    const Eigen::Vector3f v = normal.cross(u);
    angles.clear();
    grid.ForEachNeighbourOf(static_cast<int>(k), radius, [&](int j, float) {
      if (j == static_cast<int>(k)) return;
      const Eigen::Vector3f d = points[j] - points[k];
      angles.push_back(std::atan2(d.dot(v), d.dot(u)));
    });
    if (angles.size() < 2) {
      ++count;  // isolated: nothing around it on any side
      continue;
    }
    std::sort(angles.begin(), angles.end());
    double gap = angles.front() + 2 * M_PI - angles.back();
    for (size_t a = 1; a < angles.size(); ++a) gap = std::max(gap, angles[a] - angles[a - 1]);
    count += gap > threshold;
  }
  return static_cast<double>(count) / tested;
}

}  // namespace

void SgfOptions::Check() const {
  Require(voxel_size_m >= 0.002 && voxel_size_m <= 0.1,
          "sgf voxel_size_m " + std::to_string(voxel_size_m) + " must be in [0.002, 0.1]");
  Require(
      boundary_radius_m >= 0.005 && boundary_radius_m <= 0.2,
      "sgf boundary_radius_m " + std::to_string(boundary_radius_m) + " must be in [0.005, 0.2]");
  Require(boundary_angle_deg >= 10 && boundary_angle_deg <= 180,
          "sgf boundary_angle_deg " + std::to_string(boundary_angle_deg) + " must be in [10, 180]");
}

SgfVector ComputeSgf(const PointCloud& cloud,
                     const std::vector<int>& segment,
                     const SgfOptions& options) {
  options.Check();
  Require(segment.size() >= 3,
          "a segment needs at least 3 points for features (has " + std::to_string(segment.size()) +
              ")");
  SgfVector f{};
  const double n = static_cast<double>(segment.size());

  // Centroid and covariance (population, so the eigenvalues are the variances
  // of the projections on the eigenvectors).
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (int i : segment) centroid += cloud.points[i].cast<double>();
  centroid /= n;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (int i : segment) {
    const Eigen::Vector3d d = cloud.points[i].cast<double>() - centroid;
    covariance += d * d.transpose();
  }
  covariance /= n;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  // Eigen sorts ascending; e1 is the largest.
  const double e1 = std::max(0.0, solver.eigenvalues()(2)),
               e2 = std::max(0.0, solver.eigenvalues()(1)),
               e3 = std::max(0.0, solver.eigenvalues()(0));
  const Eigen::Vector3d axes[3] = {
      solver.eigenvectors().col(2), solver.eigenvectors().col(1), solver.eigenvectors().col(0)};
  const double sum = e1 + e2 + e3;

  // Projections: extents both ways and variances along each axis.
  double plus[3] = {0, 0, 0}, minus[3] = {0, 0, 0}, variance[3] = {0, 0, 0};
  std::vector<uint64_t> voxels;  // packed cell coordinates, counted once sorted
  voxels.reserve(segment.size());
  double curvature_sum = 0;
  for (int i : segment) {
    const Eigen::Vector3d d = cloud.points[i].cast<double>() - centroid;
    for (int k = 0; k < 3; ++k) {
      const double t = axes[k].dot(d);
      plus[k] = std::max(plus[k], t);
      minus[k] = std::max(minus[k], -t);
      variance[k] += t * t / n;
    }
    const Eigen::Vector3f& p = cloud.points[i];
    voxels.push_back(VoxelKey(p, options.voxel_size_m));
    curvature_sum += cloud.curvature[i];
  }
  const double voxel_volume = std::pow(options.voxel_size_m, 3);
  std::sort(voxels.begin(), voxels.end());
  const size_t occupied = std::unique(voxels.begin(), voxels.end()) - voxels.begin();
  const double occupied_volume = occupied * voxel_volume;
  double extent[3];
  for (int k = 0; k < 3; ++k) extent[k] = plus[k] + minus[k];

  f[0] = BoundaryProportion(cloud, segment, options);
  f[1] = curvature_sum / n;
  f[2] = occupied_volume;
  f[3] = SafeRatio(e2, e1);
  f[4] = SafeRatio(e3, e2);
  f[5] = SafeRatio(e3, e1);
  f[6] = SafeRatio(e1, sum);
  f[7] = SafeRatio(e2, sum);
  f[8] = SafeRatio(e3, sum);
  for (int k = 0; k < 3; ++k) f[9 + k] = variance[k];
  f[12] = std::abs(axes[2].z());
  for (int k = 0; k < 3; ++k) f[13 + k] = extent[k];
  for (int k = 0; k < 3; ++k)
    f[16 + k] = SafeRatio(std::min(plus[k], minus[k]), std::max(plus[k], minus[k]));
  f[19] = SafeRatio(extent[0], extent[1]);
  for (int k = 0; k < 3; ++k) f[20 + k] = SafeRatio(variance[k], extent[k]);
  double box_volume = 1;
  for (int k = 0; k < 3; ++k) box_volume *= std::max(extent[k], options.voxel_size_m);
  f[23] = SafeRatio(occupied_volume, box_volume);
  return f;
}

}  // namespace furn
