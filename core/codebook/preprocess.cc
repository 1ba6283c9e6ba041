#include "core/codebook/preprocess.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "core/geometry/neighbour_grid.h"
#include "core/geometry/voxel_grid.h"
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

// The finite points, thinned by the voxel grid when voxel_size_m > 0.
std::vector<Eigen::Vector3f> VoxelThinned(const std::vector<Eigen::Vector3f>& points,
                                          double voxel_size_m) {
  if (voxel_size_m > 0) return VoxelCentroids(points, static_cast<float>(voxel_size_m));
  std::vector<Eigen::Vector3f> finite;
  finite.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) finite.push_back(p);
  }
  return finite;
}

// A point's neighbours as offsets from their mean (double), with their
// squared distances to the point; reused by every point a thread fits.
struct Neighbourhood {
  std::vector<std::pair<int, float>> found;  // (index, squared distance)
  std::vector<Eigen::Vector3d> offsets;      // base[j] - mean, in the order found
};

// The quadric w = c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2 over the plane
// (u, v, normal) through the neighbours' mean, weighted least squares with
// Gaussian weights exp(-d^2 / r^2); its height and slopes at (u, v), or the
// plane (zeros) when it is ill-posed. Only the normal matrix's lower
// triangle is summed: it is all LDLT reads (each entry the same sum of
// (w b_r) b_c as the full outer product's).
Eigen::Vector3d QuadricAt(const Neighbourhood& near,
                          const Eigen::Vector3d& normal,
                          const Eigen::Vector3d& u_axis,
                          const Eigen::Vector3d& v_axis,
                          double inverse_h2,
                          double u,
                          double v) {
  if (near.found.size() < 6) return Eigen::Vector3d::Zero();
  // The 21 sums in locals, unrolled (registers; summed into the matrix's
  // memory they were a chain of stores and reloads per neighbour).
  double lower[21] = {};  // column by column: (0,0), (1,0), ..., (5,0), (1,1), ...
  double sums[6] = {};
  for (size_t k = 0; k < near.found.size(); ++k) {
    const Eigen::Vector3d& d = near.offsets[k];
    const double du = d.dot(u_axis), dv = d.dot(v_axis), dw = d.dot(normal);
    const double weight = std::exp(-near.found[k].second * inverse_h2);
    const double basis[6] = {1, du, dv, du * du, du * dv, dv * dv};
    int entry = 0;
#pragma GCC unroll 6
    for (int c = 0; c < 6; ++c) {
#pragma GCC unroll 6
      for (int r = c; r < 6; ++r) lower[entry++] += (weight * basis[r]) * basis[c];
    }
    const double weighted_height = weight * dw;
#pragma GCC unroll 6
    for (int r = 0; r < 6; ++r) sums[r] += weighted_height * basis[r];
  }
  Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs;
  int entry = 0;
  for (int c = 0; c < 6; ++c) {
    for (int r = c; r < 6; ++r) normal_matrix(r, c) = lower[entry++];
    rhs[c] = sums[c];
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>, Eigen::Lower> ldlt(normal_matrix);
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
                Neighbourhood* near,
                float radius,
                const Eigen::Vector3f& sensor_origin) {
  Fitted out;
  const double count = static_cast<double>(near->found.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& [j, d2] : near->found) mean += base[j].cast<double>();
  mean /= count;
  near->offsets.clear();
  // The covariance's six sums of d_r d_c in locals (Eigen's d * d^T went
  // through a temporary on the stack whose reloads stalled on its stores).
  double xx = 0, yx = 0, zx = 0, yy = 0, zy = 0, zz = 0;
  for (const auto& [j, d2] : near->found) {
    const Eigen::Vector3d d = base[j].cast<double>() - mean;
    near->offsets.push_back(d);
    xx += d.x() * d.x();
    yx += d.y() * d.x();
    zx += d.z() * d.x();
    yy += d.y() * d.y();
    zy += d.z() * d.y();
    zz += d.z() * d.z();
  }
  Eigen::Matrix3d covariance;
  covariance << xx, yx, zx, yx, yy, zy, zx, zy, zz;
  covariance /= count;
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
  const Eigen::Vector3d w = QuadricAt(*near, normal, u_axis, v_axis, inverse_h2, u, v);
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
    Neighbourhood near;
    const size_t end = std::min(base.size(), static_cast<size_t>(chunk + 1) * kChunk);
    for (size_t i = static_cast<size_t>(chunk) * kChunk; i < end; ++i) {
      near.found.clear();
      grid.ForEachNeighbourOf(
          static_cast<int>(i), radius, [&](int j, float d2) { near.found.emplace_back(j, d2); });
      if (static_cast<int>(near.found.size()) < options.min_neighbours) continue;
      fitted[i] = FitPoint(base, i, &near, radius, sensor_origin);
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
