// A point cloud with per-point normals and curvature, as preprocessing
// produces it for segmentation and features (training scans and detection
// scans go through the same code).
#pragma once

#include <Eigen/Core>
#include <vector>

namespace furn {

struct PointCloud {
  std::vector<Eigen::Vector3f> points;   // metres
  std::vector<Eigen::Vector3f> normals;  // unit, oriented towards the sensor
  std::vector<float> curvature;  // smallest eigenvalue / sum of eigenvalues, local covariance

  size_t size() const { return points.size(); }
};

}  // namespace furn
