// A CAD model's shape as pose fitting and verification see it.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace furn {

// A CAD model as its training scans saw it, in the model frame (origin at the
// footprint centre on the floor, yaw 0): the union of its views' points and
// normals, one per shape voxel (the first in view order). Pose fitting and
// visibility verification use it.
struct ModelShape {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;
  Eigen::Vector3f low = Eigen::Vector3f::Zero();  // bounding box of the points
  Eigen::Vector3f high = Eigen::Vector3f::Zero();
};

}  // namespace furn
