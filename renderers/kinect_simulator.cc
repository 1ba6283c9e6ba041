#include "renderers/kinect_simulator.h"

namespace furn {

KinectSimulator::KinectSimulator(DepthRenderer* renderer, const KinectNoiseOptions& noise)
    : renderer_(renderer), noise_(noise) {}

const KinectCapture& KinectSimulator::Capture(const Scene& scene,
                                              const CameraIntrinsics& camera,
                                              const Eigen::Isometry3d& world_from_camera,
                                              uint64_t seed) {
  renderer_->RenderInto(scene, camera, world_from_camera, &capture_.ideal);
  noise_.Apply(capture_.ideal, camera, seed, &capture_.noisy);
  return capture_;
}

KinectCapture CaptureKinect(DepthRenderer* renderer,
                            const Scene& scene,
                            const CameraIntrinsics& camera,
                            const Eigen::Isometry3d& world_from_camera,
                            const KinectNoiseOptions& noise,
                            uint64_t seed) {
  KinectSimulator simulator(renderer, noise);
  return simulator.Capture(scene, camera, world_from_camera, seed);
}

}  // namespace furn
