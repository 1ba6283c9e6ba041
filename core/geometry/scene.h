// A scene to render or scan: triangle meshes placed in the world, each with an
// instance id that the renderers write into their id images (0 = nothing).
//
//   Scene scene;
//   scene.objects.push_back({std::make_shared<TriangleMesh>(MakeBox(...)),
//                            PoseXYYaw(1.0, 2.0, M_PI / 2),
//                            /*instance_id=*/3});
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/geometry/mesh.h"

namespace furn {

struct SceneObject {
  std::shared_ptr<const TriangleMesh> mesh;
  Eigen::Isometry3d world_from_object = Eigen::Isometry3d::Identity();
  uint16_t instance_id = 0;  // written to id images; 0 means background
};

struct Scene {
  std::vector<SceneObject> objects;

  size_t NumTriangles() const {
    size_t total = 0;
    for (const SceneObject& object : objects)
      total += object.mesh ? object.mesh->NumTriangles() : 0;
    return total;
  }
};

// An upright pose: translation (x, y, z) and rotation `yaw` radians about z.
// Instance ids of room structure; furniture and clutter start at
// kFirstObjectId.
inline constexpr uint16_t kNoObjectId = 0;
inline constexpr uint16_t kFloorId = 1;
inline constexpr uint16_t kWallId = 2;
inline constexpr uint16_t kFirstObjectId = 10;

inline Eigen::Isometry3d PoseXYZYaw(double x, double y, double z, double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(x, y, z));
  pose.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return pose;
}

// world_from_camera for a camera at `position` looking along `forward` (world
// frame) with no roll: camera x = right, y = down, z = forward.
Eigen::Isometry3d LookAlong(const Eigen::Vector3d& position, const Eigen::Vector3d& forward);

}  // namespace furn
