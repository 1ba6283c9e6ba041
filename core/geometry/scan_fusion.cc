#include "core/geometry/scan_fusion.h"

#include <pcl/common/io.h>
#include <pcl/features/normal_3d.h>
#include <pcl/filters/filter.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/transformation_estimation_point_to_plane.h>
#include <pcl/registration/warp_point_rigid_3d.h>
#include <pcl/search/kdtree.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <unordered_set>

#include "core/geometry/pcl_conversion.h"
#include "core/geometry/voxel_key.h"
#include "core/util/error.h"
#include "core/util/random.h"

namespace furn {
namespace {

void RequireScans(const std::vector<DetectionInput>& scans, size_t reference) {
  Require(!scans.empty(), "scan fusion needs at least one scan");
  Require(reference < scans.size(),
          "scan fusion: reference scan " + std::to_string(reference) + " of " +
              std::to_string(scans.size()) + " scans");
}

void RequirePoses(const std::vector<DetectionInput>& scans) {
  for (size_t k = 0; k < scans.size(); ++k)
    Require(scans[k].world_from_camera.has_value(),
            "scan fusion: scan " + std::to_string(k + 1) + " of " + std::to_string(scans.size()) +
                " has no pose (every scan needs its camera's pose in one floor-aligned frame)");
}

// The scan's finite points within range of its sensor, in the world frame,
// one per voxel (the first in scan order: the same cloud every time).
// Planar registration leaves out the floor: it pins nothing in x, y or yaw,
// and its many well-paired points would hide a wall's misfit from the
// acceptance test (with them 6 % of poses off 2 cm / 1 degree were refined).
std::vector<Eigen::Vector3f> ThinnedWorldPoints(const DetectionInput& scan,
                                                const ScanRegistrationOptions& options) {
  const Eigen::Isometry3f world_from_camera = scan.world_from_camera->cast<float>();
  const float range = static_cast<float>(options.max_range_m);
  const float lowest = options.planar ? 0.05f : -std::numeric_limits<float>::infinity();
  std::unordered_set<uint64_t> taken;
  std::vector<Eigen::Vector3f> kept;
  for (const Eigen::Vector3f& p : scan.points) {
    if (!p.allFinite() || p.norm() > range) continue;
    const Eigen::Vector3f world = world_from_camera * p;
    if (world.z() < lowest) continue;
    if (taken.insert(VoxelKey(world, options.voxel_m)).second) kept.push_back(world);
  }
  return kept;
}

struct Pairing {
  double rms_m = std::numeric_limits<double>::quiet_NaN();
  int paired = 0;
};

// How near `points` moved by `motion` lie to the tree's: the root mean
// square of the nearest distances within `reach`.
Pairing PairingOf(const pcl::KdTreeFLANN<pcl::PointXYZ>& tree,
                  const std::vector<Eigen::Vector3f>& points,
                  const Eigen::Isometry3f& motion,
                  double reach) {
  std::vector<int> index(1);
  std::vector<float> squared(1);
  double sum = 0;
  Pairing out;
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector3f q = motion * p;
    if (tree.nearestKSearch(pcl::PointXYZ(q.x(), q.y(), q.z()), 1, index, squared) < 1 ||
        squared[0] > reach * reach)
      continue;
    sum += squared[0];
    ++out.paired;
  }
  if (out.paired > 0) out.rms_m = std::sqrt(sum / out.paired);
  return out;
}

// The points with their surface normals (within 3.5 voxels); points without
// enough neighbours for a normal are left out.
pcl::PointCloud<pcl::PointNormal>::Ptr WithNormals(const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud,
                                                   double voxel_m) {
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimate;
  estimate.setInputCloud(cloud);
  estimate.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimate.setRadiusSearch(3.5 * voxel_m);
  pcl::PointCloud<pcl::Normal> normals;
  estimate.compute(normals);
  pcl::PointCloud<pcl::PointNormal> joined;
  pcl::concatenateFields(*cloud, normals, joined);
  auto out = pcl::make_shared<pcl::PointCloud<pcl::PointNormal>>();
  pcl::Indices kept;
  pcl::removeNaNNormalsFromPointCloud(joined, *out, kept);
  return out;
}

// The motion of `points` onto `target` (with its normals) in x, y and yaw:
// point-to-plane ICP whose step is solved by Levenberg-Marquardt over PCL's
// three-parameter warp.
std::optional<Eigen::Matrix4d> PlanarMotion(const pcl::PointCloud<pcl::PointNormal>::Ptr& target,
                                            const std::vector<Eigen::Vector3f>& points,
                                            const ScanRegistrationOptions& options) {
  using Point = pcl::PointNormal;
  auto estimation = pcl::make_shared<
      pcl::registration::TransformationEstimationPointToPlane<Point, Point, double>>();
  estimation->setWarpFunction(
      pcl::make_shared<pcl::registration::WarpPointRigid3D<Point, Point, double>>());
  pcl::IterativeClosestPointWithNormals<Point, Point, double> icp;
  icp.setTransformationEstimation(estimation);
  icp.setInputSource(WithNormals(ToPclPoints(points), options.voxel_m));
  icp.setInputTarget(target);
  icp.setMaxCorrespondenceDistance(options.max_correspondence_m);
  icp.setMaximumIterations(options.iterations);
  icp.setTransformationEpsilon(1e-8);
  pcl::PointCloud<Point> aligned;
  icp.align(aligned);
  if (!icp.hasConverged()) return std::nullopt;
  return icp.getFinalTransformation();
}

// All six degrees of freedom by GICP.
std::optional<Eigen::Matrix4d> FullMotion(const pcl::PointCloud<pcl::PointXYZ>::Ptr& target,
                                          const std::vector<Eigen::Vector3f>& points,
                                          const ScanRegistrationOptions& options) {
  // In double: PCL's float instantiation trips GCC 12's -Warray-bounds in
  // Eigen's umeyama, and the sums of a room's points are better in double.
  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ, double> gicp;
  gicp.setInputSource(ToPclPoints(points));
  gicp.setInputTarget(target);
  gicp.setMaxCorrespondenceDistance(options.max_correspondence_m);
  gicp.setMaximumIterations(options.iterations);
  gicp.setTransformationEpsilon(1e-8);
  pcl::PointCloud<pcl::PointXYZ> aligned;
  gicp.align(aligned);
  if (!gicp.hasConverged()) return std::nullopt;
  return gicp.getFinalTransformation();
}

// The motion of `points` onto the tree's cloud (planar or full, as the
// options say; planar needs the target's normals), or nothing when it did
// not converge, paired worse than `before`, or moved beyond the options'
// bounds.
std::optional<Eigen::Isometry3f> Alignment(
    const pcl::PointCloud<pcl::PointXYZ>::Ptr& target,
    const pcl::PointCloud<pcl::PointNormal>::Ptr& target_normals,
    const pcl::KdTreeFLANN<pcl::PointXYZ>& tree,
    const std::vector<Eigen::Vector3f>& points,
    const Pairing& before,
    const ScanRegistrationOptions& options,
    Pairing* after) {
  const std::optional<Eigen::Matrix4d> found = options.planar
                                                   ? PlanarMotion(target_normals, points, options)
                                                   : FullMotion(target, points, options);
  if (!found || !found->allFinite()) return std::nullopt;
  const Eigen::Isometry3f motion(found->cast<float>());
  *after = PairingOf(tree, points, motion, options.max_correspondence_m);
  const double turn_deg = Eigen::AngleAxisf(motion.linear()).angle() * 180 / M_PI;
  if (!(after->rms_m < (1 - options.min_improvement) * before.rms_m) ||
      after->paired < before.paired / 2 || motion.translation().norm() > options.max_shift_m ||
      turn_deg > options.max_turn_deg)
    return std::nullopt;
  return motion;
}

}  // namespace

void ScanRegistrationOptions::Check() const {
  auto positive = [](double value, const char* name) {
    Require(
        std::isfinite(value) && value > 0,
        std::string("scan registration: ") + name + " " + std::to_string(value) + " must be > 0");
  };
  positive(max_range_m, "max_range_m");
  positive(max_correspondence_m, "max_correspondence_m");
  positive(max_shift_m, "max_shift_m");
  positive(max_turn_deg, "max_turn_deg");
  Require(std::isfinite(voxel_m) && voxel_m >= 0.01 && voxel_m <= 0.5,
          "scan registration: voxel_m " + std::to_string(voxel_m) + " must be in 0.01..0.5");
  Require(std::isfinite(min_improvement) && min_improvement >= 0 && min_improvement < 1,
          "scan registration: min_improvement " + std::to_string(min_improvement) +
              " must be in [0, 1)");
  Require(min_pairs >= 10,
          "scan registration: min_pairs " + std::to_string(min_pairs) + " must be >= 10");
  Require(iterations >= 1 && iterations <= 1000,
          "scan registration: iterations " + std::to_string(iterations) + " must be in 1..1000");
}

std::vector<RegisteredPose> RegisterScans(const std::vector<DetectionInput>& scans,
                                          size_t reference,
                                          const ScanRegistrationOptions& options) {
  options.Check();
  RequireScans(scans, reference);
  RequirePoses(scans);
  const pcl::PointCloud<pcl::PointXYZ>::Ptr target =
      ToPclPoints(ThinnedWorldPoints(scans[reference], options));
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  if (!target->empty()) tree.setInputCloud(target);
  // The reference's normals, once for every scan aligned to it (planar only).
  const pcl::PointCloud<pcl::PointNormal>::Ptr target_normals =
      options.planar && !target->empty() ? WithNormals(target, options.voxel_m) : nullptr;
  constexpr int kFewest = 10;  // fewer points in the reference: nothing to align to
  std::vector<RegisteredPose> out(scans.size());
  for (size_t k = 0; k < scans.size(); ++k) {
    RegisteredPose& pose = out[k];
    pose.world_from_camera = *scans[k].world_from_camera;
    if (k == reference || static_cast<int>(target->size()) < kFewest) continue;
    const std::vector<Eigen::Vector3f> points = ThinnedWorldPoints(scans[k], options);
    const Pairing before =
        PairingOf(tree, points, Eigen::Isometry3f::Identity(), options.max_correspondence_m);
    pose.rms_before_m = pose.rms_after_m = before.rms_m;
    pose.paired = before.paired;
    if (before.paired < options.min_pairs) continue;
    Pairing after;
    const std::optional<Eigen::Isometry3f> motion =
        Alignment(target, target_normals, tree, points, before, options, &after);
    if (!motion) continue;
    pose.world_from_camera = motion->cast<double>() * pose.world_from_camera;
    pose.rms_after_m = after.rms_m;
    pose.paired = after.paired;
    pose.refined = true;
  }
  return out;
}

std::vector<DetectionInput> WithRegisteredPoses(std::vector<DetectionInput> scans,
                                                size_t reference,
                                                const ScanRegistrationOptions& options) {
  const std::vector<RegisteredPose> poses = RegisterScans(scans, reference, options);
  for (size_t k = 0; k < scans.size(); ++k) scans[k].world_from_camera = poses[k].world_from_camera;
  return scans;
}

DetectionInput FuseScans(const std::vector<DetectionInput>& scans, size_t reference) {
  RequireScans(scans, reference);
  if (scans.size() == 1) return scans.front();
  RequirePoses(scans);
  const Eigen::Isometry3d camera_from_world = scans[reference].world_from_camera->inverse();
  size_t total = 0;
  for (const DetectionInput& scan : scans) total += scan.points.size();
  DetectionInput fused;
  fused.world_from_camera = scans[reference].world_from_camera;
  fused.points.reserve(total);
  for (const DetectionInput& scan : scans) {
    const Eigen::Isometry3f to_reference =
        (camera_from_world * *scan.world_from_camera).cast<float>();
    for (const Eigen::Vector3f& point : scan.points)
      if (point.allFinite()) fused.points.push_back(to_reference * point);
  }
  return fused;
}

Eigen::Isometry3d PerturbedPose(
    const Eigen::Isometry3d& pose, double sigma_m, double sigma_rad, FastRng& rng, bool planar) {
  Require(sigma_m >= 0 && std::isfinite(sigma_m) && sigma_rad >= 0 && std::isfinite(sigma_rad),
          "pose error: the spreads must be finite and >= 0");
  // Drawn in a fixed order, so a seed gives one error on every platform.
  const double tx = sigma_m * rng.Normal(), ty = sigma_m * rng.Normal();
  double tz = sigma_m * rng.Normal();
  double rx = sigma_rad * rng.Normal(), ry = sigma_rad * rng.Normal();
  const double rz = sigma_rad * rng.Normal();
  if (planar) tz = rx = ry = 0;
  const Eigen::Matrix3d turn = (Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  Eigen::Isometry3d out = pose;
  out.linear() = turn * pose.linear();
  out.translation() = pose.translation() + Eigen::Vector3d(tx, ty, tz);
  return out;
}

void CheckPoseErrorSpreads(double sigma_m, double sigma_deg, const std::string& what) {
  auto spread = [&what](double value, double limit, const char* unit) {
    char text[32];
    std::snprintf(text, sizeof(text), "%g", value);
    Require(std::isfinite(value) && value >= 0 && value <= limit,
            what + " " + text + " " + unit + " must be in 0.." +
                std::to_string(static_cast<int>(limit)) + " " + unit);
  };
  spread(sigma_m, 1, "m");
  spread(sigma_deg, 45, "degrees");
}

}  // namespace furn
