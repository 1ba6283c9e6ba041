// Preprocessing shared by training and detection (SPEC.md §7.2): voxel
// downsampling (PCL's VoxelGrid to the bit, core/geometry/voxel_grid.h),
// normals from a local quadric fit (moving least squares, polynomial order
// 2, Gaussian weights; points projected onto the quadric) oriented towards
// the sensor, and curvature = smallest eigenvalue / sum of eigenvalues of
// the local covariance. The fit is our own, on a neighbour grid and all
// cores: PCL's MovingLeastSquares plus NormalEstimation took 10 us a point,
// five times the detection budget allows.
//
//   PreprocessOptions options;                      // 2 cm voxels, 3 cm radius
//   PointCloud cloud = Preprocess(points, sensor_origin, options);
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/geometry/point_cloud.h"

namespace furn {

struct PreprocessOptions {
  double voxel_size_m = 0.02;     // voxel grid leaf (m), 0 to skip (0 or 0.005..0.1); tuned
  double normal_radius_m = 0.03;  // neighbourhood of the quadric fit and curvature (m, 0.01..0.2)
  int min_neighbours = 5;         // points with fewer neighbours in the radius are dropped (>= 3)

  // Throws InputError naming the field and the rule.
  void Check() const;
};

// Non-finite input points are ignored. Returns an empty cloud when nothing
// is left.
PointCloud Preprocess(const std::vector<Eigen::Vector3f>& points,
                      const Eigen::Vector3f& sensor_origin,
                      const PreprocessOptions& options);

}  // namespace furn
