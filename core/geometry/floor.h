// The floor of a scan whose camera pose is unknown (SPEC.md §8.1): the largest
// plane found by RANSAC whose normal lies within a tilt of the camera's up
// direction (-y in the optical frame: x right, y down, z forward) and that
// lies below the camera (a ceiling's normal towards the camera points down,
// and it is refused however large), with the camera's height within the
// mounting range and almost nothing below the plane; then a
// world frame with that plane as z = 0, z up, the camera above the origin and
// x along the camera's viewing direction projected on the floor. PCL's
// RANSAC draws from a fixed seed, so the result is deterministic.
//
//   FloorOptions options;
//   Eigen::Isometry3d world_from_camera = FindFloor(points_in_camera, options);
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace furn {

struct FloorOptions {
  double distance_m = 0.02;   // RANSAC inlier distance (m, 0.002..0.2)
  int iterations = 300;       // RANSAC iterations (10..100000)
  int sample_points = 20000;  // RANSAC draws from every k-th point, about this many (1000..1000000)
  double max_tilt_deg = 45;   // largest angle between the floor normal and camera up (1..89)
  double min_fraction = 0.01;        // the floor's share of the points lower than the camera (0..1)
  double min_camera_height_m = 0.2;  // a floor closer to the camera than this is rejected ...
  double max_camera_height_m = 3.0;  // ... and one farther below it (m): no sensor mount is higher

  void Check() const;
};

// The world frame of a floor plane n.p + d = 0 in camera coordinates (n unit,
// towards the camera, d > 0 the camera's height): z = n, the camera above
// the origin, x along the camera's viewing direction projected on the floor.
// Returns world_from_camera.
Eigen::Isometry3d WorldOfFloor(const Eigen::Vector3d& normal, double offset);

// The detector's floor stage (SPEC.md §8.1) for a camera-frame scan: FindFloor
// among the points within `search_range_m` of the camera, its outcome in a
// status rather than an exception (a frame without a floor in view is an
// outcome, not an error).
inline constexpr double kFloorSearchRangeM = 6;  // a level view's floor lies beyond the furniture
struct FloorEstimate {
  bool found = false;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  std::string message;  // why none was found
};
FloorEstimate EstimateFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                            const FloorOptions& options,
                            double search_range_m);

// The floor among all the given points: not found (the message says why)
// when fewer than 100 are finite or no plane satisfies the options.
FloorEstimate SearchFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                          const FloorOptions& options);

// SearchFloor for callers that want an exception: throws InputError with its
// message ("no floor found ...") when it finds none.
Eigen::Isometry3d FindFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                            const FloorOptions& options);

// The points (x[i], y[i], z[i]) within `threshold` of the plane
// c0 x + c1 y + c2 z + c3 = 0: the floor RANSAC's inner loop. The same count as PCL's plane model
// to the point: PCL's distance is Eigen's dot product of the coefficients with (x, y, z, 1), which
// sums the products as (c0 x + c2 z) + (c1 y + c3), and `|d| < threshold` compares the float with a
// double; the same sums here, against the largest float below the threshold (tested against PCL's
// count at the threshold). Eight points at a time where the CPU has AVX2 (kBest), four elsewhere:
// the same count either way; `path` forces one (kAvx2 on a CPU without AVX2 is an error).
enum class SimdPath { kBest, kSse2, kAvx2 };
size_t CountNearPlane(const std::vector<float>& x,
                      const std::vector<float>& y,
                      const std::vector<float>& z,
                      const Eigen::Vector4f& coefficients,
                      double threshold,
                      SimdPath path = SimdPath::kBest);

// Which of `points` have a surface facing up (within max_tilt_deg of the camera's up, either
// side): the plane of each point's 12 nearest neighbours, as PCL's NormalEstimation with a
// k-d tree computes it (the same queries, the same covariance and eigen solver, so the same
// normals to the bit; tested), each point on its own across the cores. The floor search's
// second pass (a real room seen level, where the floor is a sliver among walls): 20,000 points
// took 30-35 ms in NormalEstimation's one loop.
std::vector<bool> FacingUpPoints(const std::vector<Eigen::Vector3f>& points, double max_tilt_deg);

}  // namespace furn
