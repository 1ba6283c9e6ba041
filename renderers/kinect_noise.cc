#include "renderers/kinect_noise.h"

#include <cmath>
#include <limits>

#include "core/util/error.h"
#include "core/util/parallel.h"
#include "core/util/random.h"

namespace furn {
namespace {

constexpr double kHalfPi = M_PI / 2;
// Streams of DeriveSeed(seed, ...) for the two random stages, per row.
constexpr uint64_t kDropoutStream = 0;
constexpr uint64_t kNoiseStream = 1ull << 32;
// The correlated fields' seeds: DeriveSeed(seed, kFieldStream + field).
constexpr uint64_t kFieldStream = 2ull << 32;

bool SameCamera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy;
}

// Whether a 4-neighbour of (u, v) has no return or a depth jump above
// jump_m (neighbours outside the image do not count).
bool IsDepthEdge(const DepthFrame& frame, int u, int v, float jump_m) {
  const float* row = frame.depth.data() + frame.Index(0, v);
  const float z = row[u];
  auto differs = [&](float neighbour) {
    return neighbour <= 0 || std::abs(neighbour - z) > jump_m;
  };
  return (u + 1 < frame.width && differs(row[u + 1])) || (u > 0 && differs(row[u - 1])) ||
         (v + 1 < frame.height && differs(row[u + frame.width])) ||
         (v > 0 && differs(row[u - frame.width]));
}

// Lateral noise moves where a pixel samples the ideal image by round(sigma_L *
// N(0, 1)) pixels along each axis. sigma_L depends on the incidence angle only,
// so the integer offset is drawn from a per-angle inverse-CDF table indexed by
// 12 random bits: no normal variate, no branch. Probabilities are resolved to
// 1/4096, which keeps offsets of up to 3 sigma.
class LateralOffsetTable {
 public:
  static constexpr int kBins = 64;  // over the incidence cosine in [0, 1]
  static constexpr int kBits = 12;

  LateralOffsetTable() {
    for (int bin = 0; bin < kBins; ++bin) {
      // Angles beyond 88 degrees are clamped: such pixels return nothing anyway.
      const double cosine = std::max((bin + 0.5) / kBins, std::cos(88 * M_PI / 180));
      const double sigma = LateralNoiseSigmaPx(std::acos(cosine));
      int offset = -8;
      for (int slot = 0; slot < (1 << kBits); ++slot) {
        const double quantile = (slot + 0.5) / (1 << kBits);
        // P(round(sigma * N) <= k) = Phi((k + 0.5) / sigma).
        while (0.5 * std::erfc(-(offset + 0.5) / (sigma * M_SQRT2)) < quantile) ++offset;
        offsets_[bin][slot] = static_cast<int8_t>(offset);
      }
    }
  }

  // Two offsets (u, v) from 24 random bits.
  void Draw(float cosine, uint64_t bits, int* du, int* dv) const {
    const int8_t* table = offsets_[std::min(kBins - 1, static_cast<int>(cosine * kBins))];
    *du = table[bits & ((1 << kBits) - 1)];
    *dv = table[(bits >> kBits) & ((1 << kBits) - 1)];
  }

 private:
  int8_t offsets_[kBins][1 << kBits];
};

const LateralOffsetTable& LateralOffsets() {
  static const LateralOffsetTable table;
  return table;
}

// The angle factor of the axial noise above 60 degrees, theta^2 / (pi/2 -
// theta)^2, tabulated over the incidence cosine in [0, 0.5] (linear
// interpolation; it is 0 below 60 degrees).
class AxialAngleTable {
 public:
  static constexpr int kSize = 1024;
  AxialAngleTable() {
    for (int i = 0; i <= kSize; ++i) {
      const double theta = std::acos(std::max(0.5 * i / kSize, std::cos(89.5 * M_PI / 180)));
      const double ratio = theta / (kHalfPi - theta);
      factor_[i] = static_cast<float>(ratio * ratio);
    }
  }
  float Factor(float cosine) const {
    if (cosine >= 0.5f) return 0.0f;
    const float x = cosine * (2 * kSize);
    const int i = static_cast<int>(x);
    return factor_[i] + (x - i) * (factor_[i + 1] - factor_[i]);
  }

 private:
  float factor_[kSize + 1];
};

const AxialAngleTable& AxialAngles() {
  static const AxialAngleTable table;
  return table;
}

// Per image row, right to left: a point at column u and depth z meets the
// projector at column u - fx*b/z; it is shadowed when a pixel to its right
// already met the projector at the same or a smaller column.
void ComputeProjectorShadow(const DepthFrame& ideal,
                            const CameraIntrinsics& camera,
                            double baseline_m,
                            std::vector<uint8_t>* shadow_mask) {
  std::vector<uint8_t>& shadow = *shadow_mask;
  shadow.assign(ideal.depth.size(), 0);
  const double disparity_scale = camera.fx * baseline_m;
  ParallelFor(0, ideal.height, [&](int v) {
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
  });
}

}  // namespace

void KinectNoiseOptions::Check() const {
  Require(std::isfinite(baseline_m) && baseline_m > 0,
          "baseline_m " + std::to_string(baseline_m) + " must be > 0");
  Require(std::isfinite(min_range_m) && std::isfinite(max_range_m) && min_range_m >= 0 &&
              max_range_m > min_range_m,
          "range limits " + std::to_string(min_range_m) + ".." + std::to_string(max_range_m) +
              " m must satisfy 0 <= min < max");
  Require(max_incidence_deg > 0 && max_incidence_deg <= 90,
          "max_incidence_deg " + std::to_string(max_incidence_deg) + " must be in (0, 90]");
  Require(edge_jump_m > 0, "edge_jump_m " + std::to_string(edge_jump_m) + " must be > 0");
  Require(edge_dropout_probability >= 0 && edge_dropout_probability <= 1,
          "edge_dropout_probability " + std::to_string(edge_dropout_probability) +
              " must be in [0, 1]");
  Require(disparity_step_px > 0 && disparity_step_px <= 1,
          "disparity_step_px " + std::to_string(disparity_step_px) + " must be in (0, 1]");
  Require(std::isfinite(noise_scale) && noise_scale > 0 && noise_scale <= 10,
          "noise_scale " + std::to_string(noise_scale) + " must be in (0, 10]");
  Require(correlated_share >= 0 && correlated_share <= 1,
          "correlated_share " + std::to_string(correlated_share) + " must be in [0, 1]");
  Require(correlation_radius_px >= 1 && correlation_radius_px <= 16,
          "correlation_radius_px " + std::to_string(correlation_radius_px) + " must be in 1..16");
}

void CorrelatedNormalField(int width,
                           int height,
                           int radius,
                           uint64_t seed,
                           std::vector<float>* field,
                           std::vector<float>* scratch) {
  Require(width > 0 && height > 0 && radius >= 0,
          "a correlated field needs a positive size and a radius >= 0");
  const int window = 2 * radius + 1;
  const int padded_width = width + 2 * radius, padded_height = height + 2 * radius;
  // Per padded row, the sums of `window` independent normals ending at each column.
  scratch->assign(static_cast<size_t>(padded_height) * width, 0.0f);
  float* const sums = scratch->data();
  ParallelFor(0, padded_height, [&](int y) {
    FastRng rng(DeriveSeed(seed, static_cast<uint64_t>(y)));
    std::vector<double> white(static_cast<size_t>(padded_width));
    for (double& w : white) w = rng.Normal();
    double sum = 0;
    for (int k = 0; k < window; ++k) sum += white[k];
    float* out = sums + static_cast<size_t>(y) * width;
    out[0] = static_cast<float>(sum);
    for (int x = 1; x < width; ++x) {
      sum += white[x + window - 1] - white[x - 1];
      out[x] = static_cast<float>(sum);
    }
  });
  field->assign(static_cast<size_t>(width) * height, 0.0f);
  float* const values = field->data();
  const float norm = 1.0f / static_cast<float>(window);
  ParallelFor(0, height, [&](int v) {
    float* out = values + static_cast<size_t>(v) * width;
    for (int k = 0; k < window; ++k) {
      const float* in = sums + static_cast<size_t>(v + k) * width;
      for (int u = 0; u < width; ++u) out[u] += in[u];
    }
    for (int u = 0; u < width; ++u) out[u] *= norm;
  });
}

inline double AxialSigma(double z, double theta) {
  double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
  if (theta > M_PI / 3) {
    const double ratio = theta / (kHalfPi - theta);
    sigma += 0.0001 / std::sqrt(z) * ratio * ratio;
  }
  return sigma;
}

double AxialNoiseSigma(double z, double theta) { return AxialSigma(z, theta); }

double LateralNoiseSigmaPx(double theta) { return 0.8 + 0.035 * theta / (kHalfPi - theta); }

std::vector<uint8_t> ProjectorShadowMask(const DepthFrame& ideal,
                                         const CameraIntrinsics& camera,
                                         double baseline_m) {
  std::vector<uint8_t> shadow;
  ComputeProjectorShadow(ideal, camera, baseline_m, &shadow);
  return shadow;
}

KinectNoiseModel::KinectNoiseModel(const KinectNoiseOptions& options) : options_(options) {
  options_.Check();
}

DepthFrame ApplyKinectNoise(const DepthFrame& ideal,
                            const CameraIntrinsics& camera,
                            const KinectNoiseOptions& options,
                            uint64_t seed) {
  KinectNoiseModel model(options);
  DepthFrame noisy;
  model.Apply(ideal, camera, seed, &noisy);
  return noisy;
}

void KinectNoiseModel::Apply(const DepthFrame& ideal,
                             const CameraIntrinsics& camera,
                             uint64_t seed,
                             DepthFrame* noisy) {
  camera.Check();
  Require(ideal.width == camera.width && ideal.height == camera.height,
          "depth frame " + std::to_string(ideal.width) + "x" + std::to_string(ideal.height) +
              " does not match the camera " + std::to_string(camera.width) + "x" +
              std::to_string(camera.height));
  Require(ideal.normals.size() == ideal.depth.size(),
          "the sensor model needs normals: render with set_compute_normals(true)");
  CacheUnitRays(camera);
  MarkReturns(ideal, camera, seed);
  if (options_.quantization) {
    TabulateQuantisation(camera.fx * options_.baseline_m / options_.disparity_step_px);
  }
  MakeCorrelatedFields(ideal.width, ideal.height, seed);
  Resample(ideal, camera, seed, noisy);
}

void KinectNoiseModel::MakeCorrelatedFields(int width, int height, uint64_t seed) {
  if (options_.correlated_share <= 0) return;
  const int radius = options_.correlation_radius_px;
  if (options_.axial_noise)
    CorrelatedNormalField(
        width, height, radius, DeriveSeed(seed, kFieldStream), &axial_field_, &field_scratch_);
  if (options_.lateral_noise) {
    CorrelatedNormalField(width,
                          height,
                          radius,
                          DeriveSeed(seed, kFieldStream + 1),
                          &lateral_u_field_,
                          &field_scratch_);
    CorrelatedNormalField(width,
                          height,
                          radius,
                          DeriveSeed(seed, kFieldStream + 2),
                          &lateral_v_field_,
                          &field_scratch_);
  }
}

void KinectNoiseModel::CacheUnitRays(const CameraIntrinsics& camera) {
  if (SameCamera(camera, rays_camera_) && !unit_rays_.empty()) return;
  unit_rays_.resize(static_cast<size_t>(camera.width) * camera.height);
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      unit_rays_[static_cast<size_t>(v) * camera.width + u] =
          camera.RayThroughPixel(u, v).normalized();
    }
  }
  rays_camera_ = camera;
}

void KinectNoiseModel::MarkReturns(const DepthFrame& ideal,
                                   const CameraIntrinsics& camera,
                                   uint64_t seed) {
  const KinectNoiseOptions& options = options_;
  const int width = ideal.width, height = ideal.height;
  const size_t count = ideal.depth.size();
  returns_.assign(count, 0);
  incidence_cosine_.assign(count, 1.0f);
  if (options.projector_shadow) {
    ComputeProjectorShadow(ideal, camera, options.baseline_m, &shadow_);
  } else {
    shadow_.assign(count, 0);
  }
  const float min_cosine = static_cast<float>(std::cos(options.max_incidence_deg * M_PI / 180));
  const float edge_jump = static_cast<float>(options.edge_jump_m);
  // Raw pointers: the compiler cannot keep vector members in registers across
  // the stores of the loop below.
  const float* const depth = ideal.depth.data();
  const Eigen::Vector3f* const normals = ideal.normals.data();
  const Eigen::Vector3f* const rays = unit_rays_.data();
  const uint8_t* const shadow = shadow_.data();
  float* const cosines = incidence_cosine_.data();
  uint8_t* const returns = returns_.data();
  ParallelFor(0, height, [&](int v) {
    FastRng rng(DeriveSeed(seed, kDropoutStream + v));
    const size_t row = static_cast<size_t>(v) * width;
    for (int u = 0; u < width; ++u) {
      const size_t i = row + u;
      const float z = depth[i];
      if (z <= 0) continue;
      const float cosine = std::min(1.0f, std::abs(normals[i].dot(rays[i])));
      cosines[i] = cosine;
      bool keep = !shadow[i];
      if (options.range_limits) keep = keep && z >= options.min_range_m && z <= options.max_range_m;
      if (options.incidence_dropout) keep = keep && cosine >= min_cosine;
      if (options.edge_dropout && IsDepthEdge(ideal, u, v, edge_jump)) {
        // Drawn whether or not the pixel is kept, so streams do not depend on other effects.
        keep = rng.Uniform01() >= options.edge_dropout_probability && keep;
      }
      returns[i] = keep;
    }
  });
}

void KinectNoiseModel::TabulateQuantisation(double steps_per_metre) {
  if (steps_per_metre == steps_per_metre_) return;
  // Down to 5 cm of depth; nearer (more steps) is computed as it comes.
  depth_of_steps_.resize(static_cast<size_t>(steps_per_metre / 0.05) + 2);
  depth_of_steps_[0] = 0;
  for (size_t n = 1; n < depth_of_steps_.size(); ++n)
    depth_of_steps_[n] = steps_per_metre / static_cast<double>(n);
  steps_per_metre_ = steps_per_metre;
}

void KinectNoiseModel::Resample(const DepthFrame& ideal,
                                const CameraIntrinsics& camera,
                                uint64_t seed,
                                DepthFrame* noisy_frame) const {
  const KinectNoiseOptions& options = options_;
  const int width = ideal.width, height = ideal.height;
  const size_t count = ideal.depth.size();
  // A depth sensor measures no normals: the noisy frame has depth and ids only.
  DepthFrame& noisy = *noisy_frame;
  noisy.width = width;
  noisy.height = height;
  noisy.depth.assign(count, 0.0f);
  noisy.instance_ids.assign(count, 0);
  noisy.normals.clear();
  const double steps_per_metre = camera.fx * options.baseline_m / options.disparity_step_px;
  const size_t tabulated_steps = depth_of_steps_.size();
  const LateralOffsetTable& lateral = LateralOffsets();
  const AxialAngleTable& axial_angle = AxialAngles();
  const float* const depth = ideal.depth.data();
  const float* const cosines = incidence_cosine_.data();
  const uint8_t* const returns = returns_.data();
  const double* const depth_of_steps = depth_of_steps_.data();
  const uint16_t* const ideal_ids = ideal.instance_ids.data();
  float* const noisy_depth = noisy.depth.data();
  uint16_t* const noisy_ids = noisy.instance_ids.data();
  // The published model per pixel through its tables; scaled or partly
  // correlated noise computes each draw (white and field parts of unit
  // variance, weighted to keep sigma).
  const bool shaped = options.noise_scale != 1.0 || options.correlated_share > 0;
  const double white_weight = std::sqrt(1 - options.correlated_share);
  const double field_weight = std::sqrt(options.correlated_share);
  const bool fields = options.correlated_share > 0;
  const float* const axial_field = fields && options.axial_noise ? axial_field_.data() : nullptr;
  const float* const u_field = fields && options.lateral_noise ? lateral_u_field_.data() : nullptr;
  const float* const v_field = fields && options.lateral_noise ? lateral_v_field_.data() : nullptr;
  const float min_cosine = static_cast<float>(std::cos(88 * M_PI / 180));
  ParallelFor(0, height, [&](int v) {
    FastRng rng(DeriveSeed(seed, kNoiseStream + v));
    const size_t row = static_cast<size_t>(v) * width;
    // A unit-variance draw for pixel i: white, or white and field mixed.
    auto unit = [&](const float* field, size_t i) {
      const double white = rng.Normal();
      return field == nullptr ? white : white_weight * white + field_weight * field[i];
    };
    for (int u = 0; u < width; ++u) {
      int su = u, sv = v;
      if (options.lateral_noise && !shaped) {
        int du, dv;
        lateral.Draw(cosines[row + u], rng.Next(), &du, &dv);
        su += du;
        sv += dv;
      } else if (options.lateral_noise) {
        const double sigma = options.noise_scale *
                             LateralNoiseSigmaPx(std::acos(std::max(cosines[row + u], min_cosine)));
        su += static_cast<int>(std::lround(sigma * unit(u_field, row + u)));
        sv += static_cast<int>(std::lround(sigma * unit(v_field, row + u)));
      }
      if (su < 0 || sv < 0 || su >= width || sv >= height) continue;
      const size_t source = static_cast<size_t>(sv) * width + su;
      if (!returns[source]) continue;
      double z = depth[source];
      if (options.axial_noise) {
        // sigma_z of Nguyen et al.: the angle term applies above 60 degrees.
        double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
        const float angle_factor = axial_angle.Factor(cosines[source]);
        if (angle_factor > 0) sigma += 0.0001 / std::sqrt(z) * angle_factor;
        z += shaped ? options.noise_scale * sigma * unit(axial_field, row + u)
                    : sigma * rng.Normal();
      }
      if (options.quantization) {
        // Disparity is positive: adding 0.5 and truncating rounds (libm's round is slow).
        const int64_t steps = static_cast<int64_t>(steps_per_metre / z + 0.5);
        if (steps < 1) continue;  // beyond the farthest representable depth
        z = static_cast<size_t>(steps) < tabulated_steps
                ? depth_of_steps[steps]
                : steps_per_metre / static_cast<double>(steps);
      }
      noisy_depth[row + u] = static_cast<float>(z);
      noisy_ids[row + u] = ideal_ids[source];
    }
  });
}

}  // namespace furn
