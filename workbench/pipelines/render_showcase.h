// The work behind `workbench render`: one model on a floor in front of a
// wall, rendered ideal and through the Kinect v1 model, written as depth and
// id PNGs, organized PCDs, a preview and the camera as JSON.
//
//   RenderShowcaseOptions options;
//   options.out_dir = "out/render";
//   RenderOutputs outputs = RenderShowcase(catalog.LoadModel("Scopia/chair3"),
//   options);
#pragma once

#include <string>
#include <vector>

#include "core/geometry/mesh.h"
#include "renderers/camera.h"
#include "renderers/depth_renderer.h"
#include "renderers/kinect_noise.h"

namespace furn {

struct RenderShowcaseOptions {
  std::string out_dir;
  double distance_m = 2.5;  // camera distance from the model along -y (m)
  double height_m = 1.2;    // camera height (m)
  double pitch_deg = 20;    // camera pitch down (degrees)
  double yaw_deg = 0;       // model yaw (degrees)
  uint64_t seed = 1;
  RendererKind renderer = RendererKind::kOsMesa;
  CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  KinectNoiseOptions noise;
};

struct RenderOutputs {
  std::vector<std::string> files;
  size_t ideal_valid = 0;
  size_t noisy_valid = 0;
};

RenderOutputs RenderShowcase(const CadModel& model, const RenderShowcaseOptions& options);

}  // namespace furn
