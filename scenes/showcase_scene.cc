#include "scenes/showcase_scene.h"

#include <cmath>

#include "core/util/error.h"

namespace furn {

Scene MakeShowcaseScene(const CadModel& model, const ShowcaseOptions& options) {
  Require(options.Check(), "showcase scene: wall gap must be >= 0, floor and wall sizes > 0");
  Scene scene;
  const double h = options.floor_half_size_m;
  scene.objects.push_back({std::make_shared<TriangleMesh>(MakeBox(Eigen::Vector3f(-h, -h, -0.05f),
                                                                  Eigen::Vector3f(h, h, 0.0f))),
                           Eigen::Isometry3d::Identity(),
                           kFloorId});
  const Eigen::Isometry3d world_from_model = PoseXYZYaw(0, 0, 0, options.yaw_rad);
  float back = 0;
  for (const Eigen::Vector3f& p : model.mesh.vertices) {
    back = std::max(back, static_cast<float>((world_from_model * p.cast<double>()).y()));
  }
  const float wall_y = back + static_cast<float>(options.wall_gap_m);
  scene.objects.push_back({std::make_shared<TriangleMesh>(
                               MakeBox(Eigen::Vector3f(-h, wall_y, 0),
                                       Eigen::Vector3f(h, wall_y + 0.1f, options.wall_height_m))),
                           Eigen::Isometry3d::Identity(),
                           kWallId});
  scene.objects.push_back(
      {std::make_shared<TriangleMesh>(model.mesh), world_from_model, kFirstObjectId});
  return scene;
}

Eigen::Isometry3d ShowcaseCamera(double distance_m, double height_m, double pitch_deg) {
  Require(distance_m > 0 && distance_m < 100,
          "camera distance " + std::to_string(distance_m) + " m must be in (0, 100)");
  Require(height_m > 0 && height_m < 100,
          "camera height " + std::to_string(height_m) + " m must be in (0, 100)");
  Require(std::abs(pitch_deg) < 89,
          "camera pitch " + std::to_string(pitch_deg) + " degrees must be within +-89");
  const double pitch = pitch_deg * M_PI / 180;
  return LookAlong(Eigen::Vector3d(0, -distance_m, height_m),
                   Eigen::Vector3d(0, std::cos(pitch), -std::sin(pitch)));
}

}  // namespace furn
