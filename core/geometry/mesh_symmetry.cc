#include "core/geometry/mesh_symmetry.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/geometry/neighbour_grid.h"
#include "core/util/error.h"

namespace furn {
namespace {

constexpr int kSamples = 20000;
// A turn maps the mesh onto itself when its turned samples lie near the
// surface as often, less this, as a second set of samples unturned does.
constexpr double kShareLoss = 0.03;

// Points on the surface, area-weighted (the same points for a seed); the
// surface's area into *area.
std::vector<Eigen::Vector3f> SurfaceSamples(const TriangleMesh& mesh, uint64_t seed, double* area) {
  std::vector<double> cumulative;
  double total = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3f& a = mesh.vertices[t.x()];
    total += 0.5 * (mesh.vertices[t.y()] - a).cross(mesh.vertices[t.z()] - a).norm();
    cumulative.push_back(total);
  }
  Require(total > 0, "a mesh without area has no symmetry to find");
  *area = total;
  std::mt19937_64 generator(seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  std::vector<Eigen::Vector3f> samples;
  samples.reserve(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    const size_t triangle =
        std::lower_bound(cumulative.begin(), cumulative.end(), uniform(generator) * total) -
        cumulative.begin();
    const Eigen::Vector3i& t = mesh.triangles[std::min(triangle, mesh.triangles.size() - 1)];
    double u = uniform(generator), v = uniform(generator);
    if (u + v > 1) {  // fold back into the triangle
      u = 1 - u;
      v = 1 - v;
    }
    const Eigen::Vector3f& a = mesh.vertices[t.x()];
    samples.push_back(a + static_cast<float>(u) * (mesh.vertices[t.y()] - a) +
                      static_cast<float>(v) * (mesh.vertices[t.z()] - a));
  }
  return samples;
}

}  // namespace

MeshSymmetry FindVerticalSymmetry(const TriangleMesh& mesh, const Eigen::Vector3f& axis_point) {
  double area = 0;
  const std::vector<Eigen::Vector3f> surface = SurfaceSamples(mesh, 1, &area);
  const std::vector<Eigen::Vector3f> probes = SurfaceSamples(mesh, 2, &area);
  Eigen::Vector3f low = surface.front(), high = surface.front();
  for (const Eigen::Vector3f& p : surface) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  // 1.5 % of the largest side, and at least twice the samples' spacing.
  const float spacing = static_cast<float>(std::sqrt(area / kSamples));
  const float tolerance = std::max({0.005f, 0.015f * (high - low).maxCoeff(), 2 * spacing});
  const NeighbourGrid grid(surface, tolerance);
  auto share_near_surface = [&](double angle) {
    const Eigen::Matrix3f turn =
        Eigen::AngleAxisf(static_cast<float>(angle), Eigen::Vector3f::UnitZ()).toRotationMatrix();
    int near_surface = 0;
    for (const Eigen::Vector3f& p : probes) {
      bool near = false;
      grid.ForEachWithin(
          axis_point + turn * (p - axis_point), tolerance, [&](int, float) { near = true; });
      near_surface += near;
    }
    return static_cast<double>(near_surface) / probes.size();
  };
  const double unturned = share_near_surface(0);
  auto maps_onto_itself = [&](double angle) {
    return share_near_surface(angle) >= unturned - kShareLoss;
  };
  MeshSymmetry symmetry;
  // Continuous: turns that no finite order below 24 shares all map it.
  bool every_turn = true;
  for (double degrees : {17.0, 31.0, 47.0, 73.0, 101.0, 139.0}) {
    every_turn = every_turn && maps_onto_itself(degrees * M_PI / 180);
    if (!every_turn) break;
  }
  if (every_turn) {
    symmetry.continuous = true;
    return symmetry;
  }
  if (maps_onto_itself(M_PI)) {
    symmetry.order = maps_onto_itself(M_PI / 2) ? 4 : 2;
  }
  return symmetry;
}

}  // namespace furn
