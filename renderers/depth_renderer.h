// The interface both renderers implement (OSMesa rasteriser, Embree ray
// caster): ideal depth, instance ids and normals of a scene seen by a pinhole
// camera. Not thread-safe: use one renderer per thread.
//
//   std::unique_ptr<DepthRenderer> renderer =
//   MakeRenderer(RendererKind::kOsMesa); DepthFrame frame =
//   renderer->Render(scene, CameraIntrinsics::KinectV1(), world_from_camera);
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <unordered_map>

#include "core/geometry/scene.h"
#include "renderers/camera.h"
#include "renderers/depth_frame.h"

namespace furn {

class DepthRenderer {
 public:
  virtual ~DepthRenderer() = default;
  // Throws InputError for bad intrinsics, an empty scene, non-finite or absurd
  // coordinates, or a camera inside an object (see CheckRenderRequest).
  DepthFrame Render(const Scene& scene,
                    const CameraIntrinsics& camera,
                    const Eigen::Isometry3d& world_from_camera) {
    DepthFrame frame;
    RenderInto(scene, camera, world_from_camera, &frame);
    return frame;
  }
  // Same, into `frame`, reusing its memory (no page faults on a hot loop).
  virtual void RenderInto(const Scene& scene,
                          const CameraIntrinsics& camera,
                          const Eigen::Isometry3d& world_from_camera,
                          DepthFrame* frame) = 0;
  virtual std::string Name() const = 0;

  // Normals cost a little; a user needing only depth and ids can switch them
  // off (DepthFrame::normals is then empty). The sensor model needs them.
  void set_compute_normals(bool compute) { compute_normals_ = compute; }
  bool compute_normals() const { return compute_normals_; }

 private:
  bool compute_normals_ = true;
};

enum class RendererKind { kOsMesa, kEmbree };

std::unique_ptr<DepthRenderer> MakeRenderer(RendererKind kind);
// "osmesa" or "embree"; throws InputError otherwise.
RendererKind ParseRendererKind(const std::string& name);

// Bounding boxes of meshes already seen, so a renderer checks each mesh's
// coordinates once rather than every frame.
class MeshBoundsCache {
 public:
  const Box3& BoundsOf(const std::shared_ptr<const TriangleMesh>& mesh);

 private:
  struct Entry {
    std::weak_ptr<const TriangleMesh> mesh;  // detects a freed mesh whose address was reused
    Box3 bounds;
  };
  std::unordered_map<const TriangleMesh*, Entry> entries_;
};

// Validation shared by the renderers: intrinsics (Check()), a scene with at
// least one triangle, finite poses, coordinates within 1 km of the origin, and
// a camera outside every object (ray parity against the object's mesh).
void CheckRenderRequest(const Scene& scene,
                        const CameraIntrinsics& camera,
                        const Eigen::Isometry3d& world_from_camera,
                        MeshBoundsCache* bounds_cache = nullptr);

// True when `point_in_object` is inside the closed surface of `mesh`: the
// majority of three rays from it cross the surface an odd number of times.
bool IsInsideMesh(const TriangleMesh& mesh, const Eigen::Vector3d& point_in_object);

}  // namespace furn
