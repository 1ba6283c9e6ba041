#include "tests/renderers/render_fixtures.h"

#include <cmath>

#include "scenes/procedural_catalog.h"

namespace furn::testing {

Eigen::Isometry3d CameraAtOriginLookingAlongY() {
  return LookAlong(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitY());
}

SceneObject WallAt(double distance) {
  const float d = static_cast<float>(distance);
  return {std::make_shared<TriangleMesh>(MakeBox({-20, d, -20}, {20, d + 0.2f, 20})),
          Eigen::Isometry3d::Identity(),
          kWallId};
}

SceneObject BoxAt(
    double front, double x_min, double x_max, double z_min, double z_max, uint16_t id) {
  return {std::make_shared<TriangleMesh>(
              MakeBox(Eigen::Vector3d(x_min, front, z_min).cast<float>(),
                      Eigen::Vector3d(x_max, front + 0.3, z_max).cast<float>())),
          Eigen::Isometry3d::Identity(),
          id};
}

namespace {

// A floor of n x n quads over [-h, h]^2 at z = 0 (2 n^2 triangles).
TriangleMesh GridFloor(float half_size, int n) {
  TriangleMesh floor;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      floor.vertices.emplace_back(
          -half_size + 2 * half_size * i / n, -half_size + 2 * half_size * j / n, 0);
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      floor.triangles.emplace_back(a, b, d);
      floor.triangles.emplace_back(a, d, c);
    }
  }
  return floor;
}

}  // namespace

Scene FurnishedRoom(uint64_t seed, size_t target_triangles) {
  Scene scene;
  ProceduralCatalogOptions options;
  options.seed = seed;
  options.models_per_class = 2;
  options.cylinder_segments = 48;
  const auto catalog = MakeProceduralCatalog(options);
  // Catalog order: chair 0-1, armchair 2-3, table 4-5, sideboard 6-7. A table
  // with a chair on each side, armchairs at the back, sideboards against the
  // side walls (front turned into the room), a second table near the camera.
  struct Placement {
    int model;
    double x, y, yaw;
  };
  const Placement placements[] = {{4, 0.0, 3.0, 0.0},
                                  {0, -1.35, 3.0, -M_PI / 2},
                                  {1, 1.35, 3.0, M_PI / 2},
                                  {2, -1.8, 4.6, 0.3},
                                  {3, 1.8, 4.6, -0.4},
                                  {6, -3.5, 2.5, M_PI / 2},
                                  {7, 3.5, 2.5, -M_PI / 2},
                                  {5, 0.0, 0.9, 0.2}};
  uint16_t id = kFirstObjectId;
  for (const Placement& p : placements) {
    scene.objects.push_back({std::make_shared<TriangleMesh>(catalog[p.model].model.mesh),
                             PoseXYZYaw(p.x, p.y, 0, p.yaw),
                             id++});
  }
  size_t furniture_triangles = scene.NumTriangles();
  int grid = 1;
  if (target_triangles > furniture_triangles + 60) {
    grid = static_cast<int>(std::sqrt((target_triangles - furniture_triangles - 48) / 2.0));
  }
  scene.objects.push_back({std::make_shared<TriangleMesh>(GridFloor(4.0f, std::max(1, grid))),
                           PoseXYZYaw(0, 2.0, 0, 0),
                           kFloorId});
  const float h = 2.6f;
  const TriangleMesh walls[] = {MakeBox({-4, 6, 0}, {4, 6.1f, h}),
                                MakeBox({-4, -2.1f, 0}, {4, -2, h}),
                                MakeBox({-4.1f, -2, 0}, {-4, 6, h}),
                                MakeBox({4, -2, 0}, {4.1f, 6, h})};
  for (const TriangleMesh& wall : walls) {
    scene.objects.push_back(
        {std::make_shared<TriangleMesh>(wall), Eigen::Isometry3d::Identity(), kWallId});
  }
  return scene;
}

Eigen::Isometry3d FurnishedRoomCamera() {
  const double pitch = 25 * M_PI / 180;
  return LookAlong(Eigen::Vector3d(0.2, -0.5, 1.3),
                   Eigen::Vector3d(0.05, std::cos(pitch), -std::sin(pitch)));
}

}  // namespace furn::testing
