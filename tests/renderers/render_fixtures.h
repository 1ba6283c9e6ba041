// Known scenes for renderer tests and benchmarks.
#pragma once

#include "core/geometry/scene.h"
#include "renderers/camera.h"

namespace furn::testing {

// A camera at the origin looking along world +y (camera z = world y, camera
// x = world x, camera y = world -z).
Eigen::Isometry3d CameraAtOriginLookingAlongY();

// A wall whose front face is the plane y = distance, wide enough to fill a
// Kinect view from the origin; id kWallId.
SceneObject WallAt(double distance);

// A box with its front face at y = front and x in [x_min, x_max], z in
// [z_min, z_max]; 0.3 m deep.
SceneObject BoxAt(
    double front, double x_min, double x_max, double z_min, double z_max, uint16_t id);

// A furnished room: floor, four walls, procedural furniture from `seed`
// around a table (ids from kFirstObjectId). With `target_triangles` > 0 the
// floor is tessellated so the scene has about that many triangles.
Scene FurnishedRoom(uint64_t seed, size_t target_triangles = 0);
// A camera in the FurnishedRoom at 1.3 m, looking at the furniture.
Eigen::Isometry3d FurnishedRoomCamera();

}  // namespace furn::testing
