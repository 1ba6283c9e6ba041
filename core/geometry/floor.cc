#include "core/geometry/floor.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/console/print.h>
#include <pcl/features/normal_3d.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <cmath>
#include <cstdio>
#include <optional>

#include "core/geometry/pcl_conversion.h"
#include "core/util/error.h"

namespace furn {

void FloorOptions::Check() const {
  Require(distance_m >= 0.002 && distance_m <= 0.2,
          "floor distance " + std::to_string(distance_m) + " m must be in 0.002..0.2");
  Require(iterations >= 10 && iterations <= 100000,
          "floor RANSAC iterations " + std::to_string(iterations) + " must be in 10..100000");
  Require(sample_points >= 1000 && sample_points <= 1000000,
          "floor sample points " + std::to_string(sample_points) + " must be in 1000..1000000");
  Require(max_tilt_deg >= 1 && max_tilt_deg <= 89, "floor max tilt must be in 1..89 degrees");
  Require(min_fraction > 0 && min_fraction < 1, "floor min fraction must be in (0, 1)");
  Require(min_camera_height_m >= 0 && max_camera_height_m > min_camera_height_m,
          "floor camera heights must be 0 <= min < max (m), not " +
              std::to_string(min_camera_height_m) + " and " + std::to_string(max_camera_height_m));
}

Eigen::Isometry3d WorldOfFloor(const Eigen::Vector3d& normal, double offset) {
  const Eigen::Vector3d z = normal;
  Eigen::Vector3d x = Eigen::Vector3d::UnitZ() - z * z.z();
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX() - z * z.x();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_camera_rotation;
  world_from_camera_rotation.row(0) = x.transpose();
  world_from_camera_rotation.row(1) = y.transpose();
  world_from_camera_rotation.row(2) = z.transpose();
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = world_from_camera_rotation;
  world_from_camera.translation() = Eigen::Vector3d(0, 0, offset);
  return world_from_camera;
}

namespace {

// Planes RANSAC draws, one after another with the last one's points removed.
constexpr int kPlaneAttempts = 6;

// Planes found largest first by RANSAC among a fixed subsample; walls and
// table tops are skipped by the axis test or by lying above other points.
class FloorSearch {
 public:
  FloorSearch(const std::vector<Eigen::Vector3f>& sample, const FloorOptions& options)
      : sample_(sample), options_(options), cloud_(ToPclPoints(sample)) {
    // PCL prints its own complaints when a plane is not found; ours is the
    // one line the user sees.
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
    ransac_.setOptimizeCoefficients(true);
    ransac_.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
    ransac_.setMethodType(pcl::SAC_RANSAC);
    ransac_.setAxis(Eigen::Vector3f(0, -1, 0));  // camera up
    ransac_.setEpsAngle(options.max_tilt_deg * M_PI / 180);
    ransac_.setDistanceThreshold(options.distance_m);
    ransac_.setMaxIterations(options.iterations);
    ransac_.setInputCloud(cloud_);
  }

  // Planes among the `candidates` RANSAC may draw from, largest first; the
  // first that can be the floor. (Taking the lowest of those that can was
  // measured worse on NYU's real frames: planes of filled depth below the
  // floor; docs/real-scans.md.)
  std::optional<Eigen::Isometry3d> Among(const std::vector<bool>& candidates) {
    std::vector<bool> removed(sample_.size(), false);
    for (int attempt = 0; attempt < kPlaneAttempts; ++attempt) {
      auto indices = pcl::make_shared<pcl::Indices>();
      for (size_t i = 0; i < sample_.size(); ++i) {
        if (!removed[i] && candidates[i]) indices->push_back(static_cast<int>(i));
      }
      if (indices->size() < 3) break;
      ransac_.setIndices(indices);
      pcl::PointIndices inliers;
      pcl::ModelCoefficients coefficients;
      ransac_.segment(inliers, coefficients);
      if (coefficients.values.size() != 4) break;
      Eigen::Vector3d normal(
          coefficients.values[0], coefficients.values[1], coefficients.values[2]);
      double offset = coefficients.values[3];
      const double length = normal.norm();
      normal /= length;
      offset /= length;
      if (offset < 0) {  // orient towards the camera: n.c + d > 0 at c = 0
        normal = -normal;
        offset = -offset;
      }
      // A ceiling (or a plane at no mounting height) is set aside however
      // large it is: the floor may be a sliver below a large ceiling.
      if (IsBelowCamera(normal, offset)) {
        const PlaneSupport plane = SupportOf(normal, offset);
        // The floor holds a share of what lies below the camera's height.
        if (plane.support < options_.min_fraction * plane.lower) break;
        if (plane.below < 0.02 * sample_.size()) return WorldOfFloor(normal, offset);
      }
      for (int i : inliers.indices) removed[i] = true;
    }
    return std::nullopt;
  }

  // A plane's support among all sample points (not only the candidates),
  // the points below it (a floor has almost none) and those lower than the
  // camera (the floor's share is of these).
  struct PlaneSupport {
    size_t support = 0, below = 0, lower = 0;
  };
  PlaneSupport SupportOf(const Eigen::Vector3d& normal, double offset) const {
    PlaneSupport plane;
    for (const Eigen::Vector3f& p : sample_) {
      const double distance = normal.dot(p.cast<double>()) + offset;
      plane.support += std::abs(distance) <= options_.distance_m;
      plane.below += distance < -3 * options_.distance_m;
      plane.lower += distance < offset;
    }
    return plane;
  }

  // A floor lies below the camera: its normal towards the camera points up
  // (against the optical y) within the tilt, unlike a ceiling's, and the
  // camera's height above it is a mounting height.
  bool IsBelowCamera(const Eigen::Vector3d& normal, double offset) const {
    const double cos_tilt = std::cos(options_.max_tilt_deg * M_PI / 180);
    return -normal.y() >= cos_tilt && offset >= options_.min_camera_height_m &&
           offset <= options_.max_camera_height_m;
  }

  // The sample points whose surface faces up (within the tilt).
  std::vector<bool> FacingUp() const {
    pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
    estimation.setInputCloud(cloud_);
    estimation.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    estimation.setKSearch(12);
    pcl::PointCloud<pcl::Normal> normals;
    estimation.compute(normals);
    const double cos_tilt = std::cos(options_.max_tilt_deg * M_PI / 180);
    std::vector<bool> facing_up(sample_.size(), false);
    for (size_t i = 0; i < sample_.size(); ++i) {
      const pcl::Normal& n = normals[i];
      facing_up[i] = std::isfinite(n.normal_y) && std::abs(n.normal_y) >= cos_tilt;
    }
    return facing_up;
  }

 private:
  const std::vector<Eigen::Vector3f>& sample_;
  const FloorOptions& options_;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  pcl::SACSegmentation<pcl::PointXYZ> ransac_;
};

}  // namespace

FloorEstimate SearchFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                          const FloorOptions& options) {
  options.Check();
  std::vector<Eigen::Vector3f> finite;
  finite.reserve(points_in_camera.size());
  for (const Eigen::Vector3f& p : points_in_camera) {
    if (p.allFinite()) finite.push_back(p);
  }
  FloorEstimate estimate;
  if (finite.size() < 100) {
    estimate.message =
        "floor: " + std::to_string(finite.size()) + " finite points; at least 100 are needed";
    return estimate;
  }
  // RANSAC on a fixed subsample keeps it fast and deterministic.
  const size_t stride =
      std::max<size_t>(1, finite.size() / static_cast<size_t>(options.sample_points));
  std::vector<Eigen::Vector3f> sample;
  for (size_t i = 0; i < finite.size(); i += stride) sample.push_back(finite[i]);
  FloorSearch search(sample, options);
  std::optional<Eigen::Isometry3d> floor = search.Among(std::vector<bool>(sample.size(), true));
  // A small floor among large walls (a real room seen level) is rarely drawn
  // by RANSAC; again among the points whose surface faces up.
  if (!floor) floor = search.Among(search.FacingUp());
  if (floor) {
    estimate.found = true;
    estimate.world_from_camera = *floor;
    return estimate;
  }
  char why[200];
  std::snprintf(why,
                sizeof why,
                "no floor found: no plane below the camera within %g degrees of its up direction "
                "holds %g%% of the points lower than the camera with nothing below it",
                options.max_tilt_deg,
                100 * options.min_fraction);
  estimate.message = why;
  return estimate;
}

Eigen::Isometry3d FindFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                            const FloorOptions& options) {
  const FloorEstimate estimate = SearchFloor(points_in_camera, options);
  if (!estimate.found) throw InputError(estimate.message);
  return estimate.world_from_camera;
}

FloorEstimate EstimateFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                            const FloorOptions& options,
                            double search_range_m) {
  const float range2 = static_cast<float>(search_range_m * search_range_m);
  std::vector<Eigen::Vector3f> near;
  near.reserve(points_in_camera.size());
  for (const Eigen::Vector3f& p : points_in_camera) {
    if (p.allFinite() && p.squaredNorm() > 0 && p.squaredNorm() <= range2) near.push_back(p);
  }
  return SearchFloor(near, options);
}

}  // namespace furn
