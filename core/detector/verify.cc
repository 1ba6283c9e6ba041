// Stage 7 of detection: the best fit checked against what the sensor saw:
// its visibility counts against the occupancy grid (from the fit stage) and
// render-and-compare from the actual camera (organised scans).
#include "core/detector/detector_impl.h"
#include "core/util/error.h"

namespace furn {
namespace {

// The posed model rendered from the scan's camera and compared with its
// depth: by ray casting the model's mesh when the model file has meshes,
// else by splatting its shape points.
RenderComparison CompareWithDepth(const ModelMeshCaster* mesh_caster,
                                  const DetectorOptions& options,
                                  double shape_voxel_m,
                                  const PreparedScan& scan,
                                  const CandidateFit& best) {
  const Eigen::Isometry3f camera_from_world = scan.world_from_camera.inverse().cast<float>();
  const PlanarPose& pose = best.fit.pose;
  if (mesh_caster != nullptr) {
    Eigen::Isometry3f world_from_model = Eigen::Isometry3f::Identity();
    world_from_model.translation() =
        Eigen::Vector3f(static_cast<float>(pose.x), static_cast<float>(pose.y), 0.f);
    world_from_model.linear() =
        Eigen::AngleAxisf(static_cast<float>(pose.yaw), Eigen::Vector3f::UnitZ())
            .toRotationMatrix();
    return mesh_caster->Compare(best.model,
                                camera_from_world * world_from_model,
                                scan.depth,
                                scan.width,
                                scan.height,
                                *scan.intrinsics,
                                static_cast<float>(options.floor_band_m));
  }
  std::vector<Eigen::Vector3f> in_camera;
  in_camera.reserve(best.posed.size());
  for (const Eigen::Vector3f& p : best.posed) {
    if (p.z() >= options.floor_band_m) in_camera.push_back(camera_from_world * p);
  }
  return CompareRendered(in_camera,
                         scan.depth,
                         scan.width,
                         scan.height,
                         *scan.intrinsics,
                         static_cast<float>(shape_voxel_m));
}

}  // namespace

FitVerification Detector::VerifyFit(const PreparedScan& scan, const HypothesisFit& fit) const {
  Require(fit.best.has_value(), "VerifyFit needs a hypothesis with a fit");
  const DetectorOptions& options = impl_->options;
  const CandidateFit& best = *fit.best;
  FitVerification verification;
  verification.covered = best.covered;
  verification.verification = best.verification;
  verification.seen_occupied = best.counts.SeenOccupied();
  if (scan.intrinsics) {
    const RenderComparison comparison = CompareWithDepth(
        impl_->mesh_caster.get(), options, impl_->model.options.shape_voxel_m, scan, best);
    verification.seen_through = comparison.ViolationShare();
    verification.render_support = comparison.SupportShare();
  }
  verification.scorer_gates = best.covered >= options.scorer_min_covered_fraction &&
                              best.verification >= options.scorer_min_verification &&
                              verification.seen_occupied >= options.scorer_min_seen_occupied;
  return verification;
}

}  // namespace furn
