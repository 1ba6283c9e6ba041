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
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/geometry/depth_scan.h"

namespace furn {

class FastRng;

// Refining the scans' poses against one another before fusion (issue 37):
// fused with poses off by 2 cm and 1 degree, protocol E lost more than one
// frame alone gives, so odometry's poses need aligning first.
//
// Measured on protocol E's rooms (docs/learned-voting.md, "Measured: fused
// frames"): with 25 cm pairs and 5 cm voxels GICP slid correct poses by up to
// 17 cm and 4 degrees (a room's frames share little but the floor), so pairs
// are short, the clouds fine, and a correction must earn its keep.
struct ScanRegistrationOptions {
  double voxel_m = 0.03;               // each scan thinned to one point per voxel
  double max_range_m = 4.0;            // only points this near their own sensor
  double max_correspondence_m = 0.08;  // points farther apart are not paired
  int iterations = 40;
  int min_pairs = 300;  // fewer points paired at the given pose: too little shared to align
  // The paired points' root mean square distance must fall by this share
  // (Kinect noise alone gives about 2 cm at the right pose).
  double min_improvement = 0.15;
  // A correction larger than these is refused (the given pose stays): a
  // repetitive room can pull a scan onto the wrong wall.
  double max_shift_m = 0.5, max_turn_deg = 15;
  // Corrections in x, y and yaw only (point-to-plane ICP of the floor-aligned
  // clouds, PCL's WarpPointRigid3D), for scans whose height, roll and pitch
  // are right: a ground robot's odometry on a fitted floor. Else all six
  // degrees of freedom (GICP).
  bool planar = false;

  // Throws InputError naming the field and its rule.
  void Check() const;
};

// What registration did to one scan's pose.
struct RegisteredPose {
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  // Root mean square distance of its thinned points to the reference scan's
  // nearest (pairs within max_correspondence_m) before and after; NaN when
  // no point pairs.
  double rms_before_m = 0, rms_after_m = 0;
  int paired = 0;        // its points paired after
  bool refined = false;  // the correction was kept
};

// Each scan's pose refined against scans[reference]'s points by generalized
// ICP (Segal, Haehnel and Thrun 2009; PCL's GeneralizedIterativeClosestPoint)
// on voxel-thinned clouds, starting from its given pose. A correction is kept
// only when GICP converged, the paired points lie closer than before, and it
// is within the options' bounds; otherwise the given pose stays. The
// reference keeps its pose. Every scan needs a pose (InputError otherwise).
std::vector<RegisteredPose> RegisterScans(const std::vector<DetectionInput>& scans,
                                          size_t reference,
                                          const ScanRegistrationOptions& options);

// The scans with their poses as RegisterScans refines them (what fusion with
// registration fuses).
std::vector<DetectionInput> WithRegisteredPoses(std::vector<DetectionInput> scans,
                                                size_t reference,
                                                const ScanRegistrationOptions& options);

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
// centre; `planar`: along x and y and about z only (the same draws, the
// others left out). For measuring how fusion degrades with pose error.
Eigen::Isometry3d PerturbedPose(const Eigen::Isometry3d& pose,
                                double sigma_m,
                                double sigma_rad,
                                FastRng& rng,
                                bool planar = false);

// Throws InputError, "<what> <value> m must be in 0..1 m" (or degrees in
// 0..45), for a pose error's spread that is negative, not finite or larger.
void CheckPoseErrorSpreads(double sigma_m, double sigma_deg, const std::string& what);

}  // namespace furn
