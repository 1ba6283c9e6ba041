#include "core/preprocess.h"

#include <pcl/features/normal_3d.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/surface/mls.h>

#include "core/error.h"

namespace furn {

void PreprocessOptions::Check() const {
  Require(voxel_size_m == 0 || (voxel_size_m >= 0.005 && voxel_size_m <= 0.1),
          "voxel_size_m " + std::to_string(voxel_size_m) + " must be 0 or in [0.005, 0.1]");
  Require(normal_radius_m >= 0.01 && normal_radius_m <= 0.2,
          "normal_radius_m " + std::to_string(normal_radius_m) + " must be in [0.01, 0.2]");
  Require(min_neighbours >= 3,
          "min_neighbours " + std::to_string(min_neighbours) + " must be >= 3");
}

PointCloud Preprocess(const std::vector<Eigen::Vector3f>& points,
                      const Eigen::Vector3f& sensor_origin,
                      const PreprocessOptions& options) {
  options.Check();
  auto input = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  input->reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) input->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  PointCloud cloud;
  if (input->empty()) return cloud;

  auto sampled = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  if (options.voxel_size_m > 0) {
    pcl::VoxelGrid<pcl::PointXYZ> grid;
    const float leaf = static_cast<float>(options.voxel_size_m);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.setInputCloud(input);
    grid.filter(*sampled);
  } else {
    sampled = input;
  }

  // Quadric (MLS) fit: points projected onto the local surface, with its normal.
  auto tree = pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
  pcl::MovingLeastSquares<pcl::PointXYZ, pcl::PointNormal> mls;
  mls.setInputCloud(sampled);
  mls.setSearchMethod(tree);
  mls.setSearchRadius(options.normal_radius_m);
  mls.setPolynomialOrder(2);
  mls.setComputeNormals(true);
  pcl::PointCloud<pcl::PointNormal> fitted;
  mls.process(fitted);

  // Curvature from the covariance of the fitted points' neighbourhoods.
  auto fitted_xyz = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  fitted_xyz->reserve(fitted.size());
  for (const pcl::PointNormal& p : fitted) fitted_xyz->push_back(pcl::PointXYZ(p.x, p.y, p.z));
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
  estimation.setInputCloud(fitted_xyz);
  estimation.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimation.setRadiusSearch(options.normal_radius_m);
  pcl::PointCloud<pcl::Normal> covariance_normals;
  estimation.compute(covariance_normals);

  pcl::search::KdTree<pcl::PointXYZ> counter;
  counter.setInputCloud(fitted_xyz);
  std::vector<int> indices;
  std::vector<float> distances;
  for (size_t i = 0; i < fitted.size(); ++i) {
    const pcl::PointNormal& p = fitted[i];
    Eigen::Vector3f normal(p.normal_x, p.normal_y, p.normal_z);
    const float curvature = covariance_normals[i].curvature;
    if (!normal.allFinite() || normal.norm() < 0.5f || !std::isfinite(curvature)) continue;
    if (counter.radiusSearch(static_cast<int>(i), options.normal_radius_m, indices, distances) <
        options.min_neighbours) {
      continue;
    }
    const Eigen::Vector3f point(p.x, p.y, p.z);
    normal.normalize();
    if (normal.dot(sensor_origin - point) < 0) normal = -normal;
    cloud.points.push_back(point);
    cloud.normals.push_back(normal);
    cloud.curvature.push_back(curvature);
  }
  return cloud;
}

}  // namespace furn
