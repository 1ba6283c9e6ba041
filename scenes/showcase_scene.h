// One model on a floor in front of a wall: the scene of `workbench render`,
// and a simple known scene for tests.
//
//   Scene scene = MakeShowcaseScene(model, ShowcaseOptions{});
//   Eigen::Isometry3d world_from_camera = ShowcaseCamera(2.5, 1.2, 20);
#pragma once

#include "core/geometry/mesh.h"
#include "core/geometry/scene.h"

namespace furn {

struct ShowcaseOptions {
  double yaw_rad = 0;            // model rotation about z (radians)
  double wall_gap_m = 0.8;       // free space between the model's back and the wall (m, >= 0)
  double floor_half_size_m = 5;  // floor spans [-h, h] in x and y (m, > 0)
  double wall_height_m = 2.6;    // (m, > 0)

  bool Check() const { return wall_gap_m >= 0 && floor_half_size_m > 0 && wall_height_m > 0; }
};

// Floor (id kFloorId, top at z = 0), wall at +y behind the model (id
// kWallId), the model at the origin (id kFirstObjectId).
Scene MakeShowcaseScene(const CadModel& model, const ShowcaseOptions& options);

// A camera on the -y side at (0, -distance, height), looking along +y,
// pitched down by pitch_deg. Throws InputError for distance <= 0, height <= 0
// or |pitch| >= 89 degrees.
Eigen::Isometry3d ShowcaseCamera(double distance_m, double height_m, double pitch_deg);

}  // namespace furn
