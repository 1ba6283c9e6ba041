// One depth scan as the detector takes it (and scan fusion combines them).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace furn {

struct DetectionInput {
  // Camera frame (optical: x right, y down, z forward), metres; non-finite
  // points are ignored. Organised clouds may keep their NaNs.
  std::vector<Eigen::Vector3f> points;
  int width = 0, height = 0;                           // organised size, or 0 when unorganised
  std::optional<Eigen::Isometry3d> world_from_camera;  // floor at z = 0, z up
};

}  // namespace furn
