// The repository's real Kinect captures (data/real/pcl/capture0001..0005.pcd)
// as points, for tests that compare a computation with PCL's or with its
// plain definition on real data.
//
//   std::vector<Eigen::Vector3f> points;
//   ASSERT_TRUE(LoadRealCapture(2, &points));
#pragma once

#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace furn {

constexpr int kRealCaptures = 5;

inline std::string RealCapturePath(int k) {
  return std::string(FURN_SOURCE_DIR "/data/real/pcl/capture000") + std::to_string(k) + ".pcd";
}

// Capture k's points in order, NaNs included; false when it cannot be read.
inline bool LoadRealCapture(int k, std::vector<Eigen::Vector3f>* points) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  if (pcl::io::loadPCDFile(RealCapturePath(k), cloud) != 0) return false;
  points->clear();
  for (const pcl::PointXYZ& p : cloud) points->push_back(p.getVector3fMap());
  return true;
}

}  // namespace furn
