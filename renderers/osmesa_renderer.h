// Offscreen OpenGL rasteriser (Mesa's OSMesa, llvmpipe: no display, no GPU).
// One pass writes, per pixel, the camera-space depth (perspective-correct, so a
// plane renders at its exact distance to float precision) and which triangle of
// which object is seen (two 32-bit integers per pixel), read back at once; ids
// and exact face normals are then filled in on the CPU, in parallel.
// Meshes are uploaded once and cached while the renderer lives.
//
//   OsMesaRenderer renderer;
//   DepthFrame frame = renderer.Render(scene, CameraIntrinsics::KinectV1(),
//   world_from_camera);
#pragma once

#include <memory>

#include "renderers/depth_renderer.h"

namespace furn {

class OsMesaRenderer : public DepthRenderer {
 public:
  // Throws std::runtime_error when no OpenGL 3.3 core context can be created.
  OsMesaRenderer();
  ~OsMesaRenderer() override;

  void RenderInto(const Scene& scene,
                  const CameraIntrinsics& camera,
                  const Eigen::Isometry3d& world_from_camera,
                  DepthFrame* frame) override;
  using DepthRenderer::Render;
  std::string Name() const override { return "osmesa"; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace furn
