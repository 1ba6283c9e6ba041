// Sim-to-real: how far the Kinect v1 sensor model's noise is from a real
// frame's, measured on the same surfaces. The largest planes of a frame
// (floor, walls) are found and refitted; each plane pixel's depth residual
// along its ray is the real noise. The same pixels, set to the fitted
// plane's ideal depth and run through the sensor model, give the simulated
// noise. Both are binned by depth: robust standard deviation per 0.5 m,
// against a local plane of 7 x 7 pixels (what a surface's roughness looks
// like) and of 15 x 15 (which also holds the error a Kinect's window
// matching correlates over neighbours), and the share of plane pixels with
// no return. FitSensorNoise chooses the model's noise scale and correlated
// share that match both sigmas best (issue 69).
//
//   SensorNoiseComparison c = CompareSensorNoise(frames, KinectNoiseOptions{}, 7);
//   std::cout << SensorNoiseText(c);
//   const SensorFit fit = FitSensorNoise(frames, KinectNoiseOptions{}, 7);
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "renderers/camera.h"
#include "renderers/depth_frame.h"
#include "renderers/kinect_noise.h"

namespace furn {

struct NoiseBin {
  double low_m = 0, high_m = 0;
  int64_t real_pixels = 0, simulated_pixels = 0;   // with a 7 x 7 residual
  double real_sigma_m = 0, simulated_sigma_m = 0;  // 7 x 7 local plane; NaN without pixels
  double real_broad_sigma_m = 0, simulated_broad_sigma_m = 0;  // 15 x 15
  // Plane pixels without a return, of those whose 15 x 15 window is all on
  // their plane (the real frame's holes inside a plane are on it; the
  // model's come from its dropout stages).
  double real_missing_share = 0, simulated_missing_share = 0;
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

// The frames' planes found once (RANSAC, refits), their real residuals
// binned; Compare runs a sensor model on the same planes. Frames without a
// plane of at least 5 % of their pixels add nothing.
class SensorNoiseBench {
 public:
  explicit SensorNoiseBench(const std::vector<NoiseFrame>& frames);
  ~SensorNoiseBench();
  SensorNoiseComparison Compare(const KinectNoiseOptions& options, uint64_t seed) const;
  int frames() const;

 private:
  struct PlaneFrame;
  struct Samples;
  std::vector<PlaneFrame> frames_;
  std::unique_ptr<Samples> real_;
  int planes_ = 0;
};

// SensorNoiseBench(frames).Compare(options, seed).
SensorNoiseComparison CompareSensorNoise(const std::vector<NoiseFrame>& frames,
                                         const KinectNoiseOptions& options,
                                         uint64_t seed);

// The weighted root mean square of log(model sigma / real sigma) over the
// bins with kMinFitPixels in both (7 x 7 and 15 x 15 sigmas, weighted by the
// log of the pixels): 0 is a perfect match, 0.1 about 10 % off.
inline constexpr int64_t kMinFitPixels = 2000;
double SensorFitError(const SensorNoiseComparison& comparison);

// The sensor model's noise_scale, correlated_share and
// correlation_radius_px (the rest of `base` kept) of least SensorFitError:
// for every radius of kFitRadii and share of kFitShares, kFitScaleSteps
// scales, each the last one times the remaining mean sigma ratio (from 1).
// Throws InputError when no frame has planes or no bin has pixels.
inline constexpr std::array<int, 3> kFitRadii = {2, 4, 7};
inline constexpr std::array<double, 6> kFitShares = {0.0, 0.5, 0.8, 0.9, 0.95, 1.0};
inline constexpr int kFitScaleSteps = 3;
struct SensorFit {
  KinectNoiseOptions options;
  SensorNoiseComparison before, after;  // with base, and with options
  double before_error = 0, error = 0;
  int candidates = 0;
};
SensorFit FitSensorNoise(const std::vector<NoiseFrame>& frames,
                         const KinectNoiseOptions& base,
                         uint64_t seed);

std::string SensorNoiseText(const SensorNoiseComparison& comparison);
std::string SensorNoiseJson(const SensorNoiseComparison& comparison);
// {"options": {noise_scale, correlated_share, correlation_radius_px},
//  "candidates", "before_error", "error", "before": ..., "after": ...}.
std::string SensorFitJson(const SensorFit& fit);

// The noisy depth of a dataset's frames (at most `max_frames`; 0: all).
std::vector<NoiseFrame> NoiseFramesOf(const std::string& db_path, int max_frames);

}  // namespace furn
