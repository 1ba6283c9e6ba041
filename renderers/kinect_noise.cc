#include "renderers/kinect_noise.h"

#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/random.h"

namespace furn {
namespace {

constexpr double kHalfPi = M_PI / 2;
// Streams of DeriveSeed(seed, ...) for the two random stages, per row.
constexpr uint64_t kDropoutStream = 0;
constexpr uint64_t kNoiseStream = 1ull << 32;

// Angle between the viewing ray through (u, v) and the surface normal.
double IncidenceAngle(const CameraIntrinsics& camera,
                      int u,
                      int v,
                      const Eigen::Vector3f& normal) {
  const Eigen::Vector3f ray = camera.RayThroughPixel(u, v).normalized();
  const double cosine =
      std::min(1.0, static_cast<double>(std::abs(normal.dot(ray))));
  return std::acos(cosine);
}

bool IsDepthEdge(const DepthFrame& frame, int u, int v, double jump_m) {
  const float z = frame.DepthAt(u, v);
  const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
  for (int k = 0; k < 4; ++k) {
    const int nu = u + du[k], nv = v + dv[k];
    if (nu < 0 || nv < 0 || nu >= frame.width || nv >= frame.height) continue;
    const float neighbour = frame.DepthAt(nu, nv);
    if (neighbour <= 0 || std::abs(neighbour - z) > jump_m) return true;
  }
  return false;
}

}  // namespace

void KinectNoiseOptions::Check() const {
  Require(std::isfinite(baseline_m) && baseline_m > 0,
          "baseline_m " + std::to_string(baseline_m) + " must be > 0");
  Require(std::isfinite(min_range_m) && std::isfinite(max_range_m) &&
              min_range_m >= 0 && max_range_m > min_range_m,
          "range limits " + std::to_string(min_range_m) + ".." +
              std::to_string(max_range_m) + " m must satisfy 0 <= min < max");
  Require(max_incidence_deg > 0 && max_incidence_deg <= 90,
          "max_incidence_deg " + std::to_string(max_incidence_deg) +
              " must be in (0, 90]");
  Require(edge_jump_m > 0,
          "edge_jump_m " + std::to_string(edge_jump_m) + " must be > 0");
  Require(edge_dropout_probability >= 0 && edge_dropout_probability <= 1,
          "edge_dropout_probability " +
              std::to_string(edge_dropout_probability) + " must be in [0, 1]");
  Require(disparity_step_px > 0 && disparity_step_px <= 1,
          "disparity_step_px " + std::to_string(disparity_step_px) +
              " must be in (0, 1]");
}

double AxialNoiseSigma(double z, double theta) {
  double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
  if (theta > M_PI / 3) {
    const double ratio = theta / (kHalfPi - theta);
    sigma += 0.0001 / std::sqrt(z) * ratio * ratio;
  }
  return sigma;
}

double LateralNoiseSigmaPx(double theta) {
  return 0.8 + 0.035 * theta / (kHalfPi - theta);
}

std::vector<uint8_t> ProjectorShadowMask(const DepthFrame& ideal,
                                         const CameraIntrinsics& camera,
                                         double baseline_m) {
  std::vector<uint8_t> shadow(ideal.depth.size(), 0);
  const double disparity_scale = camera.fx * baseline_m;
#pragma omp parallel for schedule(static)
  for (int v = 0; v < ideal.height; ++v) {
    // Scanning right to left, the smallest projector column met so far.
    double smallest_column = std::numeric_limits<double>::infinity();
    for (int u = ideal.width - 1; u >= 0; --u) {
      const float z = ideal.DepthAt(u, v);
      if (z <= 0) continue;
      const double projector_column = u - disparity_scale / z;
      if (projector_column >= smallest_column) {
        shadow[ideal.Index(u, v)] = 1;
      } else {
        smallest_column = projector_column;
      }
    }
  }
  return shadow;
}

DepthFrame ApplyKinectNoise(const DepthFrame& ideal,
                            const CameraIntrinsics& camera,
                            const KinectNoiseOptions& options,
                            uint64_t seed) {
  options.Check();
  camera.Check();
  Require(ideal.width == camera.width && ideal.height == camera.height,
          "depth frame " + std::to_string(ideal.width) + "x" +
              std::to_string(ideal.height) + " does not match the camera " +
              std::to_string(camera.width) + "x" +
              std::to_string(camera.height));
  const int width = ideal.width, height = ideal.height;
  const size_t count = ideal.depth.size();

  // Stages 1-3 on the ideal image: which pixels return at all, and their angle.
  std::vector<uint8_t> returns(count, 0);
  std::vector<float> incidence(count, 0.0f);
  const std::vector<uint8_t> shadow =
      options.projector_shadow
          ? ProjectorShadowMask(ideal, camera, options.baseline_m)
          : std::vector<uint8_t>(count, 0);
  const double max_incidence = options.max_incidence_deg * M_PI / 180;
#pragma omp parallel for schedule(static)
  for (int v = 0; v < height; ++v) {
    FastRng rng(DeriveSeed(seed, kDropoutStream + v));
    for (int u = 0; u < width; ++u) {
      const size_t i = ideal.Index(u, v);
      const float z = ideal.depth[i];
      if (z <= 0) continue;
      incidence[i] =
          static_cast<float>(IncidenceAngle(camera, u, v, ideal.normals[i]));
      bool keep = !shadow[i];
      if (options.range_limits)
        keep = keep && z >= options.min_range_m && z <= options.max_range_m;
      if (options.incidence_dropout)
        keep = keep && incidence[i] <= max_incidence;
      if (options.edge_dropout &&
          IsDepthEdge(ideal, u, v, options.edge_jump_m)) {
        // Draw whether or not the pixel is kept, so streams do not depend on
        // other effects.
        keep = rng.Uniform01() >= options.edge_dropout_probability && keep;
      }
      returns[i] = keep;
    }
  }

  // Stages 4-6: resample at jittered positions, add axial noise, quantise.
  DepthFrame noisy;
  noisy.Resize(width, height);
  const double disparity_scale = camera.fx * options.baseline_m;
#pragma omp parallel for schedule(static)
  for (int v = 0; v < height; ++v) {
    FastRng rng(DeriveSeed(seed, kNoiseStream + v));
    for (int u = 0; u < width; ++u) {
      int su = u, sv = v;
      if (options.lateral_noise) {
        const size_t own = ideal.Index(u, v);
        const double sigma =
            LateralNoiseSigmaPx(ideal.depth[own] > 0 ? incidence[own] : 0.0);
        su = static_cast<int>(std::lround(u + sigma * rng.Normal()));
        sv = static_cast<int>(std::lround(v + sigma * rng.Normal()));
      }
      const double axial_draw = options.axial_noise ? rng.Normal() : 0.0;
      if (su < 0 || sv < 0 || su >= width || sv >= height) continue;
      const size_t source = ideal.Index(su, sv);
      if (!returns[source]) continue;
      double z = ideal.depth[source];
      if (options.axial_noise)
        z += AxialNoiseSigma(z, incidence[source]) * axial_draw;
      if (options.quantization) {
        const double disparity = disparity_scale / z;
        const double steps = std::round(disparity / options.disparity_step_px);
        if (steps < 1) continue;  // beyond the farthest representable depth
        z = disparity_scale / (steps * options.disparity_step_px);
      }
      const size_t target = noisy.Index(u, v);
      noisy.depth[target] = static_cast<float>(z);
      noisy.instance_ids[target] = ideal.instance_ids[source];
      noisy.normals[target] = ideal.normals[source];
    }
  }
  return noisy;
}

}  // namespace furn
