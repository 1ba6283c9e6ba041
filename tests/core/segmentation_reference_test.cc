// Preprocess and region growing against their definitions written plainly
// (Eigen's outer products and the full normal matrix; growth over point
// indices): the same points, normals, curvatures and segments to the bit on
// real scans, so that speeding either up can never move a segment.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/codebook/preprocess.h"
#include "core/codebook/region_growing.h"
#include "core/geometry/neighbour_grid.h"
#include "core/geometry/voxel_grid.h"
#include "tests/core/real_captures.h"

namespace furn {
namespace {

// One point's fit as SPEC §7.2 states it: the neighbourhood's covariance
// plane, the weighted quadric over it, the point projected onto it.
bool ReferenceFit(const std::vector<Eigen::Vector3f>& base,
                  size_t i,
                  const std::vector<std::pair<int, float>>& found,
                  float radius,
                  const Eigen::Vector3f& sensor,
                  Eigen::Vector3f* point,
                  Eigen::Vector3f* normal_out,
                  float* curvature) {
  const double count = static_cast<double>(found.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& [j, d2] : found) mean += base[j].cast<double>();
  mean /= count;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const auto& [j, d2] : found) {
    const Eigen::Vector3d d = base[j].cast<double>() - mean;
    covariance += d * d.transpose();
  }
  covariance /= count;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);
  const Eigen::Vector3d eigenvalues = solver.eigenvalues().cwiseMax(0.0);
  const double sum = eigenvalues.sum();
  if (!(sum > 0)) return false;
  const Eigen::Vector3d normal = solver.eigenvectors().col(0);
  const Eigen::Vector3d u_axis = solver.eigenvectors().col(2);
  const Eigen::Vector3d v_axis = normal.cross(u_axis);
  const Eigen::Vector3d q = base[i].cast<double>() - mean;
  const double u = q.dot(u_axis), v = q.dot(v_axis);
  const double inverse_h2 = 1.0 / (static_cast<double>(radius) * radius);
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  if (found.size() >= 6) {
    Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
    for (const auto& [j, d2] : found) {
      const Eigen::Vector3d d = base[j].cast<double>() - mean;
      const double du = d.dot(u_axis), dv = d.dot(v_axis), dw = d.dot(normal);
      const double weight = std::exp(-d2 * inverse_h2);
      Eigen::Matrix<double, 6, 1> b;
      b << 1, du, dv, du * du, du * dv, dv * dv;
      normal_matrix += (weight * b) * b.transpose();
      rhs += (weight * dw) * b;
    }
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>, Eigen::Lower> ldlt(normal_matrix);
    if (ldlt.info() == Eigen::Success && ldlt.isPositive()) {
      const Eigen::Matrix<double, 6, 1> c = ldlt.solve(rhs);
      if (c.allFinite())
        w = Eigen::Vector3d(c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v,
                            c[1] + 2 * c[3] * u + c[4] * v,
                            c[2] + c[4] * u + 2 * c[5] * v);
    }
  }
  const Eigen::Vector3d projected = mean + u * u_axis + v * v_axis + w[0] * normal;
  Eigen::Vector3d surface_normal = (normal - w[1] * u_axis - w[2] * v_axis).normalized();
  if (!projected.allFinite() || !surface_normal.allFinite()) return false;
  if (surface_normal.dot(sensor.cast<double>() - projected) < 0) surface_normal = -surface_normal;
  *point = projected.cast<float>();
  *normal_out = surface_normal.cast<float>();
  *curvature = static_cast<float>(eigenvalues[0] / sum);
  return true;
}

PointCloud ReferencePreprocess(const std::vector<Eigen::Vector3f>& points,
                               const Eigen::Vector3f& sensor,
                               const PreprocessOptions& options) {
  const std::vector<Eigen::Vector3f> base =
      VoxelCentroids(points, static_cast<float>(options.voxel_size_m));
  const float radius = static_cast<float>(options.normal_radius_m);
  const NeighbourGrid grid(base, radius);
  PointCloud cloud;
  for (size_t i = 0; i < base.size(); ++i) {
    std::vector<std::pair<int, float>> found;
    grid.ForEachNeighbourOf(
        static_cast<int>(i), radius, [&](int j, float d2) { found.emplace_back(j, d2); });
    if (static_cast<int>(found.size()) < options.min_neighbours) continue;
    Eigen::Vector3f point, normal;
    float curvature;
    if (!ReferenceFit(base, i, found, radius, sensor, &point, &normal, &curvature)) continue;
    cloud.points.push_back(point);
    cloud.normals.push_back(normal);
    cloud.curvature.push_back(curvature);
  }
  return cloud;
}

template <class T>
bool SameBits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

TEST(Preprocess, TheFitIsItsPlainDefinitionToTheBit) {
  std::vector<Eigen::Vector3f> real;
  ASSERT_TRUE(LoadRealCapture(2, &real)) << RealCapturePath(2);
  std::vector<Eigen::Vector3f> sphere;  // curved everywhere: the quadric's terms all count
  for (int a = 0; a < 400; ++a) {
    for (int b = 0; b < 200; ++b) {
      const double theta = M_PI * (b + 0.5) / 200, phi = 2 * M_PI * a / 400;
      sphere.emplace_back(0.3 * std::sin(theta) * std::cos(phi) + 1.0,
                          0.3 * std::sin(theta) * std::sin(phi) - 0.5,
                          0.3 * std::cos(theta) + 2.0);
    }
  }
  PreprocessOptions options;
  for (const auto* points : {&real, &sphere}) {
    const PointCloud ours = Preprocess(*points, Eigen::Vector3f::Zero(), options);
    const PointCloud reference = ReferencePreprocess(*points, Eigen::Vector3f::Zero(), options);
    ASSERT_GT(ours.size(), 1000u);
    EXPECT_TRUE(SameBits(ours.points, reference.points));
    EXPECT_TRUE(SameBits(ours.normals, reference.normals));
    EXPECT_TRUE(SameBits(ours.curvature, reference.curvature));
  }
}

// Region growing as SPEC §7.3 states it, over point indices: seeds by
// increasing curvature (ties by index), each grown through neighbours within
// delta whose normal is within alpha of the seed's.
std::vector<std::vector<int>> ReferenceRegions(const PointCloud& cloud,
                                               const RegionGrowingOptions& options) {
  const float delta = static_cast<float>(options.delta_m);
  const NeighbourGrid grid(cloud.points, delta);
  std::vector<std::pair<float, int>> by_curvature;
  for (size_t i = 0; i < cloud.size(); ++i)
    by_curvature.emplace_back(cloud.curvature[i], static_cast<int>(i));
  std::sort(by_curvature.begin(), by_curvature.end());
  const float min_cosine = static_cast<float>(std::cos(options.alpha_deg * M_PI / 180));
  std::vector<int> label(cloud.size(), -1);
  std::vector<std::vector<int>> segments;
  int next_label = 0;
  for (const auto& [curvature, seed] : by_curvature) {
    if (label[seed] != -1) continue;
    std::vector<int> segment = {seed};
    label[seed] = next_label;
    for (size_t head = 0; head < segment.size(); ++head) {
      grid.ForEachNeighbourOf(segment[head], delta, [&](int q, float) {
        if (label[q] != -1 || cloud.normals[q].dot(cloud.normals[seed]) < min_cosine) return;
        label[q] = next_label;
        segment.push_back(q);
      });
    }
    ++next_label;
    if (static_cast<int>(segment.size()) < options.min_segment_size) continue;
    std::sort(segment.begin(), segment.end());
    segments.push_back(std::move(segment));
  }
  std::stable_sort(segments.begin(), segments.end(), [](const auto& a, const auto& b) {
    return a.size() != b.size() ? a.size() > b.size() : a.front() < b.front();
  });
  return segments;
}

TEST(GrowRegions, IsItsPlainDefinitionOnRealScans) {
  PreprocessOptions preprocess;
  RegionGrowingOptions options;
  for (int k = 1; k <= kRealCaptures; ++k) {
    const std::string path = RealCapturePath(k);
    std::vector<Eigen::Vector3f> points;
    ASSERT_TRUE(LoadRealCapture(k, &points)) << path;
    const PointCloud cloud = Preprocess(points, Eigen::Vector3f::Zero(), preprocess);
    for (double alpha : {5.0, options.alpha_deg, 30.0}) {
      RegionGrowingOptions grow = options;
      grow.alpha_deg = alpha;
      const std::vector<std::vector<int>> segments = GrowRegions(cloud, grow);
      ASSERT_GT(segments.size(), 5u) << path;
      EXPECT_TRUE(segments == ReferenceRegions(cloud, grow)) << path << ", alpha " << alpha;
    }
  }
}

}  // namespace
}  // namespace furn
