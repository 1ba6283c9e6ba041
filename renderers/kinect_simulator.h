// One simulated Kinect v1 capture: the ideal frame from a renderer, and the
// noisy frame from the sensor model, from one seed.
//
//   std::unique_ptr<DepthRenderer> renderer =
//   MakeRenderer(RendererKind::kOsMesa); KinectCapture capture =
//   CaptureKinect(renderer.get(), scene, CameraIntrinsics::KinectV1(),
//                                         world_from_camera,
//                                         KinectNoiseOptions{}, seed);
#pragma once

#include "renderers/depth_renderer.h"
#include "renderers/kinect_noise.h"

namespace furn {

struct KinectCapture {
  DepthFrame ideal;
  DepthFrame noisy;
};

KinectCapture CaptureKinect(DepthRenderer* renderer,
                            const Scene& scene,
                            const CameraIntrinsics& camera,
                            const Eigen::Isometry3d& world_from_camera,
                            const KinectNoiseOptions& noise,
                            uint64_t seed);

}  // namespace furn
