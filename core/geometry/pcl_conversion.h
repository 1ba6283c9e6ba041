// Internal to core/: our point types as PCL clouds. Include only from .cc
// files (it pulls in PCL), following STYLE.md's rule on heavy headers.
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>
#include <vector>

#include "core/geometry/point_cloud.h"

namespace furn {

inline pcl::PointCloud<pcl::PointXYZ>::Ptr ToPclPoints(const std::vector<Eigen::Vector3f>& points) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(points.size());
  for (const Eigen::Vector3f& p : points) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return cloud;
}

struct PclPointsWithNormals {
  pcl::PointCloud<pcl::PointXYZ>::Ptr points;
  pcl::PointCloud<pcl::Normal>::Ptr normals;
};

// The points `indices` of `cloud`, with their normals.
inline PclPointsWithNormals ToPclPointsWithNormals(const PointCloud& cloud,
                                                   const std::vector<int>& indices) {
  PclPointsWithNormals out{pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>(),
                           pcl::make_shared<pcl::PointCloud<pcl::Normal>>()};
  out.points->reserve(indices.size());
  out.normals->reserve(indices.size());
  for (int i : indices) {
    const Eigen::Vector3f& p = cloud.points[i];
    const Eigen::Vector3f& n = cloud.normals[i];
    out.points->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    out.normals->push_back(pcl::Normal(n.x(), n.y(), n.z()));
  }
  return out;
}

}  // namespace furn
