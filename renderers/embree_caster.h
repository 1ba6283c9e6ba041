// Ray caster on Intel Embree 3 with the same camera API and outputs as the
// OSMesa renderer (ideal depth, instance ids, normals). Rays go in packets of
// 4 x 4 pixels; rows of packets run in parallel. Scenes are two-level: each
// mesh gets one object-space acceleration structure for the process (kept
// while the mesh lives, shared by all casters), and a scene is a small
// top-level structure over instances of them (and over the world-space
// triangles of meshes of up to 64 triangles, such as walls and floor), rebuilt
// only when the scene changes (other meshes, poses or ids). A catalog model
// placed in many rooms, and an object cast alone for its amodal mask, cost one
// build.
//
//   EmbreeCaster caster;
//   DepthFrame frame = caster.Render(scene, CameraIntrinsics::KinectV1(),
//   world_from_camera);
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/geometry/embree_device.h"
#include "renderers/depth_renderer.h"

namespace furn {

class EmbreeCaster : public DepthRenderer {
 public:
  // Throws std::runtime_error when Embree cannot create a device (an
  // unsupported CPU, or a bad FURN_EMBREE_CONFIG).
  EmbreeCaster();
  ~EmbreeCaster() override;

  void RenderInto(const Scene& scene,
                  const CameraIntrinsics& camera,
                  const Eigen::Isometry3d& world_from_camera,
                  DepthFrame* frame) override;
  using DepthRenderer::Render;
  std::string Name() const override { return "embree"; }

  // Builds (or keeps) the acceleration structure for `scene`; Render calls it.
  void SetScene(const Scene& scene);

  // Pixels of the inclusive region (u0, v0, u1, v1) whose ray hits the scene,
  // and their bounding box (u1 < u0 when none): an object's amodal mask when
  // the scene holds that object alone.
  struct Coverage {
    int64_t pixels = 0;
    std::array<int, 4> box = {0, 0, -1, -1};
  };
  // Shortcuts from a full-scene render of the same view (`ids` and `depth`,
  // row-major, camera size) for the scene object `id` whose depth in the
  // camera is at most `far_depth`: a pixel showing `id` is a hit (seen first in
  // the full scene, it is hit alone too); a pixel showing nothing, or a surface
  // beyond `far_depth`, is a miss (the ray would have met the object first).
  // Only pixels with something else in front are ray cast.
  struct KnownHits {
    const std::vector<uint16_t>* ids = nullptr;
    const std::vector<float>* depth = nullptr;
    uint16_t id = 0;
    float far_depth = 0;
  };
  Coverage CoverageIn(const Scene& scene,
                      const CameraIntrinsics& camera,
                      const Eigen::Isometry3d& world_from_camera,
                      const std::array<int, 4>& region,
                      KnownHits known_hits);
  Coverage CoverageIn(const Scene& scene,
                      const CameraIntrinsics& camera,
                      const Eigen::Isometry3d& world_from_camera,
                      const std::array<int, 4>& region) {
    return CoverageIn(scene, camera, world_from_camera, region, KnownHits());
  }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace furn
