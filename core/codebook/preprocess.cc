#include "core/codebook/preprocess.h"

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "core/geometry/neighbour_grid.h"
#include "core/util/error.h"
#include "core/util/parallel.h"

namespace furn {

void PreprocessOptions::Check() const {
  Require(voxel_size_m == 0 || (voxel_size_m >= 0.005 && voxel_size_m <= 0.1),
          "voxel_size_m " + std::to_string(voxel_size_m) + " must be 0 or in [0.005, 0.1]");
  Require(normal_radius_m >= 0.01 && normal_radius_m <= 0.2,
          "normal_radius_m " + std::to_string(normal_radius_m) + " must be in [0.01, 0.2]");
  Require(min_neighbours >= 3,
          "min_neighbours " + std::to_string(min_neighbours) + " must be >= 3");
}

namespace {

// A point's MLS fit: projected onto its neighbourhood's quadric, with the
// quadric's normal (towards the sensor) and the plane's curvature.
struct Fitted {
  bool kept = false;
  Eigen::Vector3f point, normal;
  float curvature = 0;
};

// The finite points, thinned by PCL's voxel grid when voxel_size_m > 0.
std::vector<Eigen::Vector3f> VoxelThinned(const std::vector<Eigen::Vector3f>& points,
                                          double voxel_size_m) {
  auto input = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  input->reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) input->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  if (input->empty()) return {};
  auto sampled = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  if (voxel_size_m > 0) {
    pcl::VoxelGrid<pcl::PointXYZ> grid;
    const float leaf = static_cast<float>(voxel_size_m);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.setInputCloud(input);
    grid.filter(*sampled);
  } else {
    sampled = input;
  }
  std::vector<Eigen::Vector3f> base;
  base.reserve(sampled->size());
  for (const pcl::PointXYZ& p : *sampled) base.emplace_back(p.x, p.y, p.z);
  return base;
}

// The quadric w = c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2 over the plane
// (u, v, normal) through `mean`, weighted least squares with Gaussian
// weights exp(-d^2 / r^2); its height and slopes at (u, v), or the plane
// (zeros) when it is ill-posed.
Eigen::Vector3d QuadricAt(const std::vector<Eigen::Vector3f>& base,
                          const std::vector<std::pair<int, float>>& neighbours,
                          const Eigen::Vector3d& mean,
                          const Eigen::Vector3d& normal,
                          const Eigen::Vector3d& u_axis,
                          const Eigen::Vector3d& v_axis,
                          double inverse_h2,
                          double u,
                          double v) {
  Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  for (const auto& [j, d2] : neighbours) {
    const Eigen::Vector3d d = base[j].cast<double>() - mean;
    const double du = d.dot(u_axis), dv = d.dot(v_axis), dw = d.dot(normal);
    const double weight = std::exp(-d2 * inverse_h2);
    Eigen::Matrix<double, 6, 1> basis;
    basis << 1, du, dv, du * du, du * dv, dv * dv;
    normal_matrix += weight * basis * basis.transpose();
    rhs += weight * dw * basis;
  }
  if (neighbours.size() < 6) return Eigen::Vector3d::Zero();
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(normal_matrix);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return Eigen::Vector3d::Zero();
  const Eigen::Matrix<double, 6, 1> c = ldlt.solve(rhs);
  if (!c.allFinite()) return Eigen::Vector3d::Zero();
  return Eigen::Vector3d(c[0] + c[1] * u + c[2] * v + c[3] * u * u + c[4] * u * v + c[5] * v * v,
                         c[1] + 2 * c[3] * u + c[4] * v,
                         c[2] + c[4] * u + 2 * c[5] * v);
}

// Point i's neighbourhood plane (covariance: normal and curvature = the
// smallest eigenvalue / sum), then its MLS quadric over that plane.
Fitted FitPoint(const std::vector<Eigen::Vector3f>& base,
                size_t i,
                const std::vector<std::pair<int, float>>& neighbours,
                float radius,
                const Eigen::Vector3f& sensor_origin) {
  Fitted out;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& [j, d2] : neighbours) mean += base[j].cast<double>();
  mean /= static_cast<double>(neighbours.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const auto& [j, d2] : neighbours) {
    const Eigen::Vector3d d = base[j].cast<double>() - mean;
    covariance += d * d.transpose();
  }
  covariance /= static_cast<double>(neighbours.size());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(covariance);
  const Eigen::Vector3d eigenvalues = solver.eigenvalues().cwiseMax(0.0);  // ascending
  const double sum = eigenvalues.sum();
  if (!(sum > 0)) return out;
  const Eigen::Vector3d normal = solver.eigenvectors().col(0);
  const Eigen::Vector3d u_axis = solver.eigenvectors().col(2);
  const Eigen::Vector3d v_axis = normal.cross(u_axis);
  const Eigen::Vector3d q = base[i].cast<double>() - mean;
  const double u = q.dot(u_axis), v = q.dot(v_axis);
  const double inverse_h2 = 1.0 / (static_cast<double>(radius) * radius);
  const Eigen::Vector3d w =
      QuadricAt(base, neighbours, mean, normal, u_axis, v_axis, inverse_h2, u, v);
  const Eigen::Vector3d projected = mean + u * u_axis + v * v_axis + w[0] * normal;
  Eigen::Vector3d surface_normal = (normal - w[1] * u_axis - w[2] * v_axis).normalized();
  if (!projected.allFinite() || !surface_normal.allFinite()) return out;
  if (surface_normal.dot(sensor_origin.cast<double>() - projected) < 0)
    surface_normal = -surface_normal;
  out.kept = true;
  out.point = projected.cast<float>();
  out.normal = surface_normal.cast<float>();
  out.curvature = static_cast<float>(eigenvalues[0] / sum);
  return out;
}

}  // namespace

PointCloud Preprocess(const std::vector<Eigen::Vector3f>& points,
                      const Eigen::Vector3f& sensor_origin,
                      const PreprocessOptions& options) {
  options.Check();
  PointCloud cloud;
  const std::vector<Eigen::Vector3f> base = VoxelThinned(points, options.voxel_size_m);
  if (base.empty()) return cloud;
  const float radius = static_cast<float>(options.normal_radius_m);
  const NeighbourGrid grid(base, radius);
  // Every point on its own: all cores, in chunks.
  std::vector<Fitted> fitted(base.size());
  constexpr int kChunk = 256;
  ParallelFor(0, static_cast<int>((base.size() + kChunk - 1) / kChunk), [&](int chunk) {
    std::vector<std::pair<int, float>> neighbours;
    const size_t end = std::min(base.size(), static_cast<size_t>(chunk + 1) * kChunk);
    for (size_t i = static_cast<size_t>(chunk) * kChunk; i < end; ++i) {
      neighbours.clear();
      grid.ForEachNeighbourOf(
          static_cast<int>(i), radius, [&](int j, float d2) { neighbours.emplace_back(j, d2); });
      if (static_cast<int>(neighbours.size()) < options.min_neighbours) continue;
      fitted[i] = FitPoint(base, i, neighbours, radius, sensor_origin);
    }
  });
  for (const Fitted& f : fitted) {
    if (!f.kept) continue;
    cloud.points.push_back(f.point);
    cloud.normals.push_back(f.normal);
    cloud.curvature.push_back(f.curvature);
  }
  return cloud;
}

}  // namespace furn
