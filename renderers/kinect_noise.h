// Kinect v1 sensor model (SPEC.md §4): turns an ideal depth frame into what
// the sensor would return. Each effect can be switched off; the result is a
// pure function of (ideal frame, camera, options, seed).
//
//  1. projector shadow: the IR projector sits baseline_m to +x of the camera;
//     a point it cannot light returns nothing. Found per image row from the
//     ideal depth alone: a point at pixel u, depth z meets the projector at
//     column u - fx*b/z, and is shadowed when a pixel to its right meets the
//     projector at the same or a smaller column (it is in front on that ray);
//  2. range: nothing below min_range_m or beyond max_range_m;
//  3. incidence: nothing where the angle between the viewing ray and the
//     normal exceeds max_incidence_deg; near depth edges, extra dropout;
//  4. lateral noise (Nguyen, Izadi, Lovell 2012): each pixel samples the
//     ideal image at a jittered position, sigma_L = 0.8 + 0.035*theta/(pi/2 -
//     theta) px;
//  5. axial noise (same paper): sigma_z = 0.0012 + 0.0019*(z - 0.4)^2 m, plus
//     0.0001/sqrt(z) * theta^2/(pi/2 - theta)^2 above 60 degrees;
//  6. disparity quantisation: d = fx*b/z rounded to 1/8 px, z' = fx*b/d.
//  Both noises may be scaled (noise_scale) and partly spatially correlated
//  (correlated_share over a window of correlation_radius_px): the fit to
//  real frames of `dataset noise --fit` sets them.
//
//   KinectNoiseOptions options;          // published defaults, all effects on
//   DepthFrame noisy = ApplyKinectNoise(ideal, CameraIntrinsics::KinectV1(),
//   options, seed);
#pragma once

#include <cstdint>
#include <vector>

#include "renderers/camera.h"
#include "renderers/depth_frame.h"

namespace furn {

struct KinectNoiseOptions {
  double baseline_m = 0.075;  // camera to IR projector along +x, metres (> 0)

  bool projector_shadow = true;

  bool range_limits = true;
  double min_range_m = 0.5;  // no return closer than this (m)
  double max_range_m = 4.5;  // no return beyond this (m)

  bool incidence_dropout = true;
  double max_incidence_deg = 78.0;  // no return above this angle (degrees, 0..90)

  bool edge_dropout = true;
  double edge_jump_m = 0.04;              // depth step to a 4-neighbour that makes an edge (m)
  double edge_dropout_probability = 0.3;  // chance an edge pixel returns nothing (0..1)

  bool lateral_noise = true;
  bool axial_noise = true;
  // Both noises' sigma times this (> 0): the published model is measured per
  // pixel on planes; a fit to real frames (`dataset noise --fit`) may scale it.
  double noise_scale = 1.0;
  // Real disparity is matched over windows (9 x 9 on a Kinect v1), so its
  // error is spatially correlated: a share of the axial and lateral noise's
  // variance (0: per pixel, the published model) comes from fields of unit
  // variance that are box means over (2 correlation_radius_px + 1)^2 pixels.
  double correlated_share = 0.0;  // 0..1
  int correlation_radius_px = 4;  // 1..16

  bool quantization = true;
  double disparity_step_px = 0.125;  // disparity resolution (px, > 0)

  // Throws InputError naming the field and the rule.
  void Check() const;
};

// Standard deviations of the noise model (theta in radians, z in metres).
double AxialNoiseSigma(double z, double theta);
double LateralNoiseSigmaPx(double theta);

// 1 where the projector cannot light the surface seen at that pixel.
std::vector<uint8_t> ProjectorShadowMask(const DepthFrame& ideal,
                                         const CameraIntrinsics& camera,
                                         double baseline_m);

// The sensor model with its working memory, for frame after frame without
// fresh allocations (page faults on new buffers cost more than the maths).
class KinectNoiseModel {
 public:
  // Throws InputError when the options fail Check().
  explicit KinectNoiseModel(const KinectNoiseOptions& options);

  // The noisy frame: depth with all enabled effects and the id of the surface
  // each returned pixel sampled (0 where nothing returned); no normals, as a
  // sensor measures none. Throws
  // InputError when the frame does not match the camera.
  void Apply(const DepthFrame& ideal,
             const CameraIntrinsics& camera,
             uint64_t seed,
             DepthFrame* noisy);

  const KinectNoiseOptions& options() const { return options_; }

 private:
  // The unit ray through every pixel of `camera`, kept while the camera stays.
  void CacheUnitRays(const CameraIntrinsics& camera);
  // Stages 1-3 on the ideal image: which pixels return at all (returns_), and
  // the cosine of their incidence angle (incidence_cosine_).
  void MarkReturns(const DepthFrame& ideal, const CameraIntrinsics& camera, uint64_t seed);
  // depth_of_steps_ for a camera of `steps_per_metre` disparity steps at 1 m.
  void TabulateQuantisation(double steps_per_metre);
  // Stages 4-6: resample at jittered positions, add axial noise, quantise.
  void Resample(const DepthFrame& ideal,
                const CameraIntrinsics& camera,
                uint64_t seed,
                DepthFrame* noisy) const;

  // The correlated fields (correlated_share > 0) for this frame's seed: one
  // for the axial noise, two for the lateral offsets, each width x height.
  void MakeCorrelatedFields(int width, int height, uint64_t seed);

  const KinectNoiseOptions options_;
  std::vector<float> axial_field_, lateral_u_field_, lateral_v_field_, field_scratch_;
  std::vector<uint8_t> shadow_;
  std::vector<uint8_t> returns_;
  std::vector<float> incidence_cosine_;
  std::vector<Eigen::Vector3f> unit_rays_;  // per pixel, for rays_camera_
  CameraIntrinsics rays_camera_;
  // depth_of_steps_[n] = steps_per_metre_ / n: the depth of a disparity of n
  // steps, so quantisation needs one division a pixel, not two.
  std::vector<double> depth_of_steps_;
  double steps_per_metre_ = 0;
};

// A width x height field of unit-variance normal values correlated over
// (2 radius + 1)^2 windows: each value is the sum of independent normals over
// its window (drawn on a grid padded by radius, so every value has a whole
// window) over 2 radius + 1. Rows are seeded by DeriveSeed(seed, row): the
// same field on any thread count. `scratch` is working memory.
void CorrelatedNormalField(int width,
                           int height,
                           int radius,
                           uint64_t seed,
                           std::vector<float>* field,
                           std::vector<float>* scratch);

// One-off convenience form of KinectNoiseModel::Apply.
DepthFrame ApplyKinectNoise(const DepthFrame& ideal,
                            const CameraIntrinsics& camera,
                            const KinectNoiseOptions& options,
                            uint64_t seed);

}  // namespace furn
