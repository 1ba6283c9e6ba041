// Several posed scans of one place as one detection input (issue 37). A
// table cut by one frame's side is often whole in another frame of the same
// room: protocol E with each frame's room-mates fused in places tables at
// 10 cm far more often than one frame can (docs/learned-voting.md,
// "Measured: fused frames").
//
//   std::vector<DetectionInput> scans = ...;  // each with its world_from_camera
//   DetectionInput fused = FuseScans(scans, scans.size() - 1);
//   DetectionResult result = detector.Detect(fused);  // seen from the last scan's camera
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "core/detector.h"  // DetectionInput

namespace furn {

class FastRng;

// Every scan's finite points in the camera frame of scans[reference], as one
// unorganised cloud with that scan's pose: detection sees the place from the
// reference camera (its grid, its range, its view for `in_view`) with the
// points of all of them. One scan is returned as it is. Throws InputError
// for no scans, a reference out of range, or (with several scans) a scan
// without a pose: fusion needs every scan in one floor-aligned world frame.
DetectionInput FuseScans(const std::vector<DetectionInput>& scans, size_t reference);

// `pose` with a random rigid error, as odometry or SLAM would give it: a
// translation of N(0, sigma_m) along each world axis and rotations of
// N(0, sigma_rad) about each, applied in the world frame about the camera's
// centre. For measuring how fusion degrades with pose error.
Eigen::Isometry3d PerturbedPose(const Eigen::Isometry3d& pose,
                                double sigma_m,
                                double sigma_rad,
                                FastRng& rng);

}  // namespace furn
