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

// A renderer and the sensor model, reusing their frames from capture to
// capture: the form for loops over many views.
class KinectSimulator {
 public:
  // `renderer` must outlive the simulator.
  KinectSimulator(DepthRenderer* renderer, const KinectNoiseOptions& noise);

  // The returned capture is valid until the next call.
  const KinectCapture& Capture(const Scene& scene,
                               const CameraIntrinsics& camera,
                               const Eigen::Isometry3d& world_from_camera,
                               uint64_t seed);

 private:
  DepthRenderer* renderer_;
  KinectNoiseModel noise_;
  KinectCapture capture_;
};

// One-off form of KinectSimulator::Capture.
KinectCapture CaptureKinect(DepthRenderer* renderer,
                            const Scene& scene,
                            const CameraIntrinsics& camera,
                            const Eigen::Isometry3d& world_from_camera,
                            const KinectNoiseOptions& noise,
                            uint64_t seed);

}  // namespace furn
