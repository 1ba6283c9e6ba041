// Sim-to-real: how far the Kinect v1 sensor model's noise is from a real
// frame's, measured on the same surfaces. The largest planes of a frame
// (floor, walls) are found and refitted; each plane pixel's depth residual
// along its ray is the real noise. The same pixels, set to the fitted
// plane's ideal depth and run through the sensor model, give the simulated
// noise. Both are binned by depth: robust standard deviation (1.4826 x MAD)
// per 0.5 m.
//
//   SensorNoiseComparison c = CompareSensorNoise(frames, KinectNoiseOptions{}, 7);
//   std::cout << SensorNoiseText(c);
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "renderers/camera.h"
#include "renderers/depth_frame.h"
#include "renderers/kinect_noise.h"

namespace furn {

struct NoiseBin {
  double low_m = 0, high_m = 0;
  int64_t real_pixels = 0, simulated_pixels = 0;
  double real_sigma_m = 0, simulated_sigma_m = 0;  // NaN without pixels
};

struct SensorNoiseComparison {
  int frames = 0, planes = 0;
  std::vector<NoiseBin> bins;  // 0.5..4.5 m by 0.5 m
};

struct NoiseFrame {
  DepthFrame depth;  // metres, 0 = no return
  CameraIntrinsics camera;
  std::string name;  // for messages
};

// Frames without a plane of at least 5 % of their pixels add nothing.
SensorNoiseComparison CompareSensorNoise(const std::vector<NoiseFrame>& frames,
                                         const KinectNoiseOptions& options,
                                         uint64_t seed);

std::string SensorNoiseText(const SensorNoiseComparison& comparison);
std::string SensorNoiseJson(const SensorNoiseComparison& comparison);

// The noisy depth of a dataset's frames (at most `max_frames`; 0: all).
std::vector<NoiseFrame> NoiseFramesOf(const std::string& db_path, int max_frames);

}  // namespace furn
