// The floor of a scan whose camera pose is unknown (SPEC.md §8.1): the largest
// plane found by RANSAC whose normal lies within a tilt of the camera's up
// direction (-y in the optical frame: x right, y down, z forward), then a
// world frame with that plane as z = 0, z up, the camera above the origin and
// x along the camera's viewing direction projected on the floor. PCL's
// RANSAC draws from a fixed seed, so the result is deterministic.
//
//   FloorOptions options;
//   Eigen::Isometry3d world_from_camera = FindFloor(points_in_camera, options);
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace furn {

struct FloorOptions {
  double distance_m = 0.02;          // RANSAC inlier distance (m, 0.002..0.2)
  int iterations = 300;              // RANSAC iterations (10..100000)
  double max_tilt_deg = 45;          // largest angle between the floor normal and camera up (1..89)
  double min_fraction = 0.03;        // the floor must hold at least this share of the points (0..1)
  double min_camera_height_m = 0.2;  // a floor closer to the camera than this is rejected

  void Check() const;
};

// Throws InputError when fewer than 100 finite points are given or no plane
// satisfies the options ("no floor found").
Eigen::Isometry3d FindFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                            const FloorOptions& options);

}  // namespace furn
