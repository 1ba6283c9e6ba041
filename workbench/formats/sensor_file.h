// Sensor files (issue 69): a Kinect sensor model's options as JSON, written
// by `dataset noise --fit --out` and read by `generate`, `train` and
// `dataset noise` with --sensor FILE:
//
//   {"format": "furnidet-sensor", "version": 1,
//    "fitted_on": "real.db, 9 frames", "fit_error": 0.08,
//    "noise": {"noise_scale": 0.6, "correlated_share": 0.85, ...}}
//
// Absent "noise" keys keep their defaults; unknown keys, wrong types and
// values KinectNoiseOptions::Check() refuses are InputErrors naming the file
// and the key. Reading never runs anything and reads at most kMaxSensorFileBytes.
//
//   const KinectNoiseOptions sensor = ReadSensorFile("kinect.json");
#pragma once

#include <cstdint>
#include <string>

#include "renderers/kinect_noise.h"

namespace furn {

inline constexpr uintmax_t kMaxSensorFileBytes = 1 << 20;

// The whole file, every option present; `fitted_on` and `fit_error` (NaN:
// left out) say where it came from.
std::string SensorFileJson(const KinectNoiseOptions& options,
                           const std::string& fitted_on,
                           double fit_error);

KinectNoiseOptions SensorOptionsFromJson(const std::string& text, const std::string& what);
KinectNoiseOptions ReadSensorFile(const std::string& path);

}  // namespace furn
