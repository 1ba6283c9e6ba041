#include "core/geometry/scene.h"

#include "core/util/error.h"

namespace furn {

Eigen::Isometry3d LookAlong(const Eigen::Vector3d& position, const Eigen::Vector3d& forward) {
  Require(forward.norm() > 1e-9, "camera forward direction must not be zero");
  const Eigen::Vector3d z = forward.normalized();
  Require(std::abs(z.z()) < 1 - 1e-9,
          "camera must not look straight up or down (roll is undefined)");
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() << x, y, z;
  world_from_camera.translation() = position;
  return world_from_camera;
}

}  // namespace furn
