// Render-and-compare verification (issue 16, step 4): the fitted model drawn
// from the actual camera and compared with the observed depth per pixel.
//
// The model is drawn by ray casting its simplified mesh with Embree
// (ModelMeshCaster: one ray per sampled pixel of the posed model's image box).
// Model files without meshes (format < 4) draw the stored surface samples by
// z-buffered splatting instead (CompareRendered): every posed sample covers a
// disc of about its voxel's size on the image, nearest wins. Per pixel:
//   - the sensor saw farther than the model surface (beyond the tolerance):
//     it saw through where the model is solid -> a violation, strong
//     evidence against (a chest where a table's knee space is);
//   - the sensor saw closer: something occludes the model -> neutral;
//   - within the tolerance: support;
//   - no return: unknown -> neutral.
// The tolerance grows with depth like the Kinect's noise (SPEC §6) plus a
// margin for the model's own shape differing from the real piece.
//
//   std::optional<PinholeIntrinsics> k = IntrinsicsOfOrganisedCloud(points, w, h);
//   ModelMeshCaster caster(&model.render_meshes);
//   RenderComparison c = caster.Compare(m, camera_from_model, depth, w, h, *k);
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <vector>

#include "core/geometry/mesh.h"
#include "core/geometry/visibility.h"

namespace furn {

struct PinholeIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

// The pinhole intrinsics that project an organised cloud's points (camera
// frame, z forward) onto their pixels, by least squares of u = fx x/z + cx
// and v = fy y/z + cy; nullopt for too few points or a poor fit (more than
// half a pixel off), e.g. a cloud that is not a pinhole image.
std::optional<PinholeIntrinsics> IntrinsicsOfOrganisedCloud(
    const std::vector<Eigen::Vector3f>& points, int width, int height);

// The pinhole camera (intrinsics and world_from_camera, optical frame: x
// right, y down, z forward) that saw an organised cloud whose points are in
// some world frame, by the direct linear transform of point-pixel pairs and
// an RQ decomposition; nullopt for too few points, a degenerate layout or a
// poor fit (more than a pixel off on average).
struct OrganisedCloudCamera {
  PinholeIntrinsics intrinsics;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
};
std::optional<OrganisedCloudCamera> CameraOfOrganisedCloud(
    const std::vector<Eigen::Vector3f>& points, int width, int height);

struct RenderComparison {
  int drawn = 0;      // pixels the model covers
  int support = 0;    // observed depth agrees
  int violation = 0;  // observed farther: seen through the model
  int occluded = 0;   // observed closer
  int unknown = 0;    // no return

  // violation / (support + violation); 0 when neither.
  double ViolationShare() const;
  // support / drawn; 0 when nothing is drawn.
  double SupportShare() const;
};

// The depth tolerance at depth z (m): 0.04 + 0.005 z^2.
float RenderTolerance(float z);

// What an organised scan says about a point (camera frame) of the room, by
// the ray through the point's pixel: free where it returned from beyond the
// point (by more than RenderTolerance), occupied where it returned there,
// hidden where in front of it, unknown out of view or without a return.
// `points`: the organised cloud's camera-frame points, width x height,
// row-major, the range cut not applied (a wall 4 m away shows the space in
// front of it free). What the learned extent fit probes edges with.
Visibility VisibilityInScan(const std::vector<Eigen::Vector3f>& points,
                            int width,
                            int height,
                            const PinholeIntrinsics& intrinsics,
                            const Eigen::Vector3d& point_in_camera);

// `model_points` in the camera frame (z forward); `depth` the observed depth
// per pixel (row-major, <= 0 or non-finite: no return); `splat_m` the
// spacing of the model's surface samples.
RenderComparison CompareRendered(const std::vector<Eigen::Vector3f>& model_points,
                                 const std::vector<float>& depth,
                                 int width,
                                 int height,
                                 const PinholeIntrinsics& intrinsics,
                                 float splat_m);

// Ray casts CAD model meshes (model frame) with Embree. Each mesh's
// acceleration structure is built at its first use and kept; Compare is
// thread-safe. The meshes must outlive the caster.
class ModelMeshCaster {
 public:
  explicit ModelMeshCaster(const std::vector<TriangleMesh>* meshes);
  ~ModelMeshCaster();
  ModelMeshCaster(const ModelMeshCaster&) = delete;
  ModelMeshCaster& operator=(const ModelMeshCaster&) = delete;

  size_t NumMeshes() const;

  // Model `model` posed by `camera_from_model` (camera frame: z forward)
  // compared with the observed `depth` (as CompareRendered) over the image box
  // of the posed mesh's bounding box, with at most about `max_rays` rays (an
  // even pixel stride over the box). Counts are of sampled pixels. Model
  // points below `min_model_z` (model frame; the floor band) are not drawn: a
  // ray whose first hit is there counts as a miss.
  RenderComparison Compare(int model,
                           const Eigen::Isometry3f& camera_from_model,
                           const std::vector<float>& depth,
                           int width,
                           int height,
                           const PinholeIntrinsics& intrinsics,
                           float min_model_z = 0,
                           int max_rays = 4096) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace furn
