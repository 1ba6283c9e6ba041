#include "core/scan_fusion.h"

#include <cmath>
#include <string>

#include "core/error.h"
#include "core/random.h"

namespace furn {

DetectionInput FuseScans(const std::vector<DetectionInput>& scans, size_t reference) {
  Require(!scans.empty(), "scan fusion needs at least one scan");
  Require(reference < scans.size(),
          "scan fusion: reference scan " + std::to_string(reference) + " of " +
              std::to_string(scans.size()) + " scans");
  if (scans.size() == 1) return scans.front();
  for (size_t k = 0; k < scans.size(); ++k)
    Require(scans[k].world_from_camera.has_value(),
            "scan fusion: scan " + std::to_string(k + 1) + " of " + std::to_string(scans.size()) +
                " has no pose (every scan needs its camera's pose in one floor-aligned frame)");
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

Eigen::Isometry3d PerturbedPose(const Eigen::Isometry3d& pose,
                                double sigma_m,
                                double sigma_rad,
                                FastRng& rng) {
  Require(sigma_m >= 0 && std::isfinite(sigma_m) && sigma_rad >= 0 && std::isfinite(sigma_rad),
          "pose error: the spreads must be finite and >= 0");
  // Drawn in a fixed order, so a seed gives one error on every platform.
  const double tx = sigma_m * rng.Normal(), ty = sigma_m * rng.Normal(),
               tz = sigma_m * rng.Normal();
  const double rx = sigma_rad * rng.Normal(), ry = sigma_rad * rng.Normal(),
               rz = sigma_rad * rng.Normal();
  const Eigen::Matrix3d turn = (Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  Eigen::Isometry3d out = pose;
  out.linear() = turn * pose.linear();
  out.translation() = pose.translation() + Eigen::Vector3d(tx, ty, tz);
  return out;
}

}  // namespace furn
