#include "renderers/kinect_simulator.h"

namespace furn {

KinectCapture CaptureKinect(DepthRenderer* renderer,
                            const Scene& scene,
                            const CameraIntrinsics& camera,
                            const Eigen::Isometry3d& world_from_camera,
                            const KinectNoiseOptions& noise,
                            uint64_t seed) {
  noise.Check();
  KinectCapture capture;
  capture.ideal = renderer->Render(scene, camera, world_from_camera);
  capture.noisy = ApplyKinectNoise(capture.ideal, camera, noise, seed);
  return capture;
}

}  // namespace furn
