#include "workbench/pipelines/sensor_noise.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/console/print.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>

#include "core/geometry/pcl_conversion.h"
#include "core/util/error.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/scan_file.h"

namespace furn {
namespace {

constexpr double kBinM = 0.5, kLowM = 0.5, kHighM = 4.5;
constexpr int kMaxPlanes = 3;
constexpr double kMinPlaneShare = 0.05;

// The band around a plane within which a pixel belongs to it: wide enough
// for the sensor's noise at depth z, narrow enough to leave objects out.
double Band(double z) { return 0.03 + 0.01 * z * z; }

// The standard deviation of the central 90 % of the values, scaled to a
// normal distribution's sigma: robust to what the plane band lets in, and
// smooth on quantised depths (where the median absolute deviation jumps
// between multiples of the disparity step).
double RobustSigma(std::vector<double> values) {
  if (values.size() < 20) return std::nan("");
  std::sort(values.begin(), values.end());
  const size_t cut = values.size() / 20;
  double sum = 0, squares = 0;
  const size_t n = values.size() - 2 * cut;
  for (size_t i = cut; i < values.size() - cut; ++i) {
    sum += values[i];
    squares += values[i] * values[i];
  }
  const double mean = sum / n;
  constexpr double kCentral90Sd = 0.7894;  // sd of a unit normal within +-1.645
  return std::sqrt(std::max(0.0, squares / n - mean * mean)) / kCentral90Sd;
}

struct Plane {
  Eigen::Vector3d normal;  // unit, towards the camera (offset > 0)
  double offset = 0;       // n.p + offset = 0
  // Robust sigma of the residuals divided by z^2 (0: not known yet).
  double normalised_sigma = 0;
  // Whether point p (at depth z) belongs to the plane: within 3 sigmas once
  // known, else within Band.
  bool Holds(const Eigen::Vector3d& p) const {
    const double distance = std::abs(normal.dot(p) + offset);
    return normalised_sigma > 0 ? distance <= std::max(0.01, 3 * normalised_sigma * p.z() * p.z())
                                : distance <= Band(p.z());
  }
};

// Least-squares plane through points (PCA), oriented towards the camera.
Plane FitPlane(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  Plane plane;
  plane.normal = solver.eigenvectors().col(0).normalized();
  plane.offset = -plane.normal.dot(mean);
  if (plane.offset < 0) {
    plane.normal = -plane.normal;
    plane.offset = -plane.offset;
  }
  return plane;
}

// A plane refitted to the points near `plane`: first within Band, then
// within 2.5 robust sigmas of the depth-normalised residuals (noise grows
// as z^2), so points of a neighbouring surface in the wide band at depth do
// not tilt it.
Plane RefitPlane(const std::vector<Eigen::Vector3d>& points, Plane plane) {
  std::vector<Eigen::Vector3d> near;
  for (const Eigen::Vector3d& p : points) {
    if (std::abs(plane.normal.dot(p) + plane.offset) <= Band(p.z())) near.push_back(p);
  }
  if (near.size() < 3) return plane;
  plane = FitPlane(near);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<double> normalised;
    for (const Eigen::Vector3d& p : near)
      normalised.push_back((plane.normal.dot(p) + plane.offset) / (p.z() * p.z()));
    const double sigma = RobustSigma(normalised);
    if (!std::isfinite(sigma) || sigma <= 0) break;
    std::vector<Eigen::Vector3d> kept;
    for (const Eigen::Vector3d& p : points) {
      if (std::abs(plane.normal.dot(p) + plane.offset) <= 2.5 * sigma * p.z() * p.z())
        kept.push_back(p);
    }
    if (kept.size() < 3) break;
    plane = FitPlane(kept);
    plane.normalised_sigma = sigma;
    near = std::move(kept);
  }
  return plane;
}

}  // namespace

namespace {

// A frame's planes (floor, walls) and which pixel lies on which.
struct FramePlanes {
  std::vector<int> pixels;              // of the points in range
  std::vector<Eigen::Vector3f> points;  // camera frame
  std::vector<int> plane_of_pixel;      // -1: on none
  std::vector<Plane> planes;
};

// Up to kMaxPlanes planes, largest first: RANSAC on a subsample, each refit
// on the full-resolution pixels near it that no earlier plane took.
void FindPlanes(FramePlanes* f) {
  std::vector<Eigen::Vector3f> sample;
  const size_t stride = std::max<size_t>(1, f->points.size() / 30000);
  for (size_t i = 0; i < f->points.size(); i += stride) sample.push_back(f->points[i]);
  auto cloud = ToPclPoints(sample);
  pcl::SACSegmentation<pcl::PointXYZ> ransac;
  ransac.setModelType(pcl::SACMODEL_PLANE);
  ransac.setMethodType(pcl::SAC_RANSAC);
  ransac.setDistanceThreshold(0.04);
  ransac.setMaxIterations(500);
  ransac.setInputCloud(cloud);
  std::vector<bool> taken_sample(sample.size(), false);
  for (int k = 0; k < kMaxPlanes; ++k) {
    auto indices = pcl::make_shared<pcl::Indices>();
    for (size_t i = 0; i < sample.size(); ++i) {
      if (!taken_sample[i]) indices->push_back(static_cast<int>(i));
    }
    if (indices->size() < 100) break;
    ransac.setIndices(indices);
    pcl::PointIndices inliers;
    pcl::ModelCoefficients coefficients;
    ransac.segment(inliers, coefficients);
    if (inliers.indices.size() < kMinPlaneShare * sample.size()) break;
    for (int i : inliers.indices) taken_sample[i] = true;
    // Refit on the full-resolution pixels near it, twice.
    Plane plane;
    plane.normal =
        Eigen::Vector3d(coefficients.values[0], coefficients.values[1], coefficients.values[2]);
    plane.offset = coefficients.values[3] / plane.normal.norm();
    plane.normal.normalize();
    std::vector<Eigen::Vector3d> free;
    for (size_t i = 0; i < f->points.size(); ++i) {
      if (f->plane_of_pixel[f->pixels[i]] < 0) free.push_back(f->points[i].cast<double>());
    }
    plane = RefitPlane(free, plane);
    const int id = static_cast<int>(f->planes.size());
    for (size_t i = 0; i < f->points.size(); ++i) {
      if (f->plane_of_pixel[f->pixels[i]] < 0 && plane.Holds(f->points[i].cast<double>()))
        f->plane_of_pixel[f->pixels[i]] = id;
    }
    f->planes.push_back(plane);
  }
}

// Pixels without a return amid a plane's pixels are on it too: the ideal
// frame must not have holes the real one had only by dropout, or the model's
// lateral jitter would drop samples it would otherwise shift.
void FillDropouts(const DepthFrame& depth, std::vector<int>* plane_of_pixel) {
  const std::vector<int> assigned = *plane_of_pixel;
  for (int v = 2; v + 2 < depth.height; ++v) {
    for (int u = 2; u + 2 < depth.width; ++u) {
      const size_t i = static_cast<size_t>(v) * depth.width + u;
      if (depth.depth[i] > 0 || assigned[i] >= 0) continue;
      std::array<int, kMaxPlanes> votes{};
      for (int dv = -2; dv <= 2; ++dv) {
        for (int du = -2; du <= 2; ++du) {
          const int k = assigned[i + static_cast<ptrdiff_t>(dv) * depth.width + du];
          if (k >= 0) ++votes[k];
        }
      }
      const int best =
          static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
      if (votes[best] >= 13) (*plane_of_pixel)[i] = best;  // most of the window
    }
  }
}

// The ideal frame: each plane pixel at its plane's depth along the ray;
// `plane_depth` gets that depth (0 elsewhere).
DepthFrame IdealFrame(const FramePlanes& f,
                      const DepthFrame& depth,
                      const CameraIntrinsics& camera,
                      std::vector<double>* plane_depth) {
  DepthFrame ideal;
  ideal.Resize(depth.width, depth.height);
  plane_depth->assign(depth.depth.size(), 0);
  for (size_t i = 0; i < depth.depth.size(); ++i) {
    const int k = f.plane_of_pixel[i];
    if (k < 0) continue;
    const int u = static_cast<int>(i % depth.width), v = static_cast<int>(i / depth.width);
    const Eigen::Vector3d ray = camera.RayThroughPixel(u, v).cast<double>();
    const double along = f.planes[k].normal.dot(ray);
    if (std::abs(along) < 1e-6) continue;
    (*plane_depth)[i] = -f.planes[k].offset / along;
    ideal.depth[i] = static_cast<float>((*plane_depth)[i]);
    ideal.instance_ids[i] = static_cast<uint16_t>(k + 1);
    ideal.normals[i] = f.planes[k].normal.cast<float>();
  }
  return ideal;
}

// Residual against a local plane: the pixel's depth minus the least-squares
// z = a + b du + c dv over its (2 radius + 1)^2 window on the same plane
// (at least `min_count` other pixels). Real and simulated depths get the
// same estimator, which a slightly misfitted global plane or a bowed wall
// does not bias. At radius 3 (7 x 7) the window is within the sensor's own
// matching window and takes up most of its correlated error; at radius 7
// (15 x 15) it does not, so the two residuals' ratio tells how much of the
// error is correlated.
bool LocalResidual(const DepthFrame& frame,
                   const std::vector<int>& plane_of_pixel,
                   size_t i,
                   int radius,
                   double* residual) {
  const int u0 = static_cast<int>(i % frame.width), v0 = static_cast<int>(i / frame.width);
  if (u0 < radius || v0 < radius || u0 + radius >= frame.width || v0 + radius >= frame.height)
    return false;
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
  Eigen::Vector3d right_side = Eigen::Vector3d::Zero();
  int count = 0;
  for (int dv = -radius; dv <= radius; ++dv) {
    for (int du = -radius; du <= radius; ++du) {
      if (du == 0 && dv == 0) continue;  // the centre is what is tested
      const size_t j = static_cast<size_t>(v0 + dv) * frame.width + (u0 + du);
      if (plane_of_pixel[j] != plane_of_pixel[i] || frame.depth[j] <= 0) continue;
      const Eigen::Vector3d x(1, du, dv);
      normal_matrix += x * x.transpose();
      right_side += x * frame.depth[j];
      ++count;
    }
  }
  const int window = (2 * radius + 1) * (2 * radius + 1) - 1;
  if (count < window * 5 / 8) return false;
  const Eigen::Vector3d fit = normal_matrix.ldlt().solve(right_side);
  *residual = frame.depth[i] - fit.x();
  return true;
}

constexpr int kLocalRadius = 3, kBroadRadius = 7;

// Per plane, summed-area tables of its returned pixels' count and depth:
// where a window holds the plane's pixels only, all of them returned, the
// least-squares plane's value at the centre is the neighbours' mean (the
// window is symmetric), found in O(1); other windows take LocalResidual.
class PlaneWindowSums {
 public:
  PlaneWindowSums(const DepthFrame& frame, const std::vector<int>& plane_of_pixel, int planes)
      : width_(frame.width + 1), height_(frame.height + 1) {
    count_.assign(static_cast<size_t>(planes), std::vector<double>(width_ * height_, 0.0));
    depth_ = count_;
    for (int k = 0; k < planes; ++k) {
      for (int v = 0; v < frame.height; ++v) {
        double row_count = 0, row_depth = 0;
        for (int u = 0; u < frame.width; ++u) {
          const size_t i = static_cast<size_t>(v) * frame.width + u;
          if (plane_of_pixel[i] == k && frame.depth[i] > 0) {
            row_count += 1;
            row_depth += frame.depth[i];
          }
          const size_t at = Index(u + 1, v + 1);
          count_[k][at] = count_[k][Index(u + 1, v)] + row_count;
          depth_[k][at] = depth_[k][Index(u + 1, v)] + row_depth;
        }
      }
    }
  }

  // Whether pixel i's window lies inside the image, all of it plane k's
  // returned pixels.
  bool Complete(const DepthFrame& frame, size_t i, int k, int radius) const {
    const int u = static_cast<int>(i % frame.width), v = static_cast<int>(i / frame.width);
    if (k < 0 || u < radius || v < radius || u + radius >= frame.width ||
        v + radius >= frame.height)
      return false;
    return Box(count_[k], u, v, radius) == (2 * radius + 1) * (2 * radius + 1);
  }

  // The residual of pixel i (plane k, returned) against its complete window,
  // or false when the window is not complete.
  bool Residual(const DepthFrame& frame, size_t i, int k, int radius, double* residual) const {
    if (!Complete(frame, i, k, radius)) return false;
    const int u = static_cast<int>(i % frame.width), v = static_cast<int>(i / frame.width);
    const int window = (2 * radius + 1) * (2 * radius + 1);
    const double neighbours = Box(depth_[k], u, v, radius) - frame.depth[i];
    *residual = frame.depth[i] - neighbours / (window - 1);
    return true;
  }

 private:
  size_t Index(int u, int v) const { return static_cast<size_t>(v) * width_ + u; }
  double Box(const std::vector<double>& table, int u, int v, int radius) const {
    const int u0 = u - radius, v0 = v - radius, u1 = u + radius + 1, v1 = v + radius + 1;
    return table[Index(u1, v1)] - table[Index(u0, v1)] - table[Index(u1, v0)] +
           table[Index(u0, v0)];
  }

  size_t width_, height_;
  std::vector<std::vector<double>> count_, depth_;
};

// The frame's points within [kLowM, kHighM).
FramePlanes PointsInRange(const DepthFrame& depth, const CameraIntrinsics& camera) {
  FramePlanes f;
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const float z = depth.depth[static_cast<size_t>(v) * depth.width + u];
      if (!(z >= kLowM && z < kHighM)) continue;
      f.pixels.push_back(v * depth.width + u);
      f.points.push_back(camera.RayThroughPixel(u, v) * z);
    }
  }
  f.plane_of_pixel.assign(depth.depth.size(), -1);
  return f;
}

}  // namespace

namespace {

int BinCount() { return static_cast<int>(std::round((kHighM - kLowM) / kBinM)); }

int BinOf(double z) { return std::min(BinCount() - 1, static_cast<int>((z - kLowM) / kBinM)); }

}  // namespace

// One frame with its planes found: the ideal frame the model is run on and
// each plane pixel's depth.
struct SensorNoiseBench::PlaneFrame {
  DepthFrame ideal;
  CameraIntrinsics camera;
  std::vector<int> plane_of_pixel;
  std::vector<double> plane_depth;
  int planes = 0;
  // Pixels whose 15 x 15 window is all on their plane: where missing depth
  // is counted (at a plane's border the bench's ideal frame ends, and the
  // model's jitter and edge dropout would meet nothing there).
  std::vector<char> interior;
};

// Per bin, the residuals (local, broad) and the plane pixels with and
// without a return.
struct SensorNoiseBench::Samples {
  std::vector<std::vector<double>> local, broad;
  std::vector<int64_t> plane_pixels, missing;
  Samples()
      : local(BinCount()), broad(BinCount()), plane_pixels(BinCount(), 0), missing(BinCount(), 0) {}

  void Add(const DepthFrame& depth, const PlaneFrame& f) {
    const PlaneWindowSums sums(depth, f.plane_of_pixel, f.planes);
    auto residual_of = [&](size_t i, int radius, double* residual) {
      return sums.Residual(depth, i, f.plane_of_pixel[i], radius, residual) ||
             LocalResidual(depth, f.plane_of_pixel, i, radius, residual);
    };
    for (size_t i = 0; i < depth.depth.size(); ++i) {
      const double z = f.plane_depth[i];
      if (z < kLowM || z >= kHighM) continue;
      const int bin = BinOf(z);
      if (f.interior[i]) {
        ++plane_pixels[bin];
        missing[bin] += depth.depth[i] <= 0;
      }
      if (depth.depth[i] <= 0) continue;
      double residual = 0;
      if (residual_of(i, kLocalRadius, &residual) && std::abs(residual) <= Band(z))
        local[bin].push_back(residual);
      if (residual_of(i, kBroadRadius, &residual) && std::abs(residual) <= Band(z))
        broad[bin].push_back(residual);
    }
  }
};

SensorNoiseBench::SensorNoiseBench(const std::vector<NoiseFrame>& frames)
    : real_(std::make_unique<Samples>()) {
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  for (const NoiseFrame& frame : frames) {
    const DepthFrame& depth = frame.depth;
    FramePlanes f = PointsInRange(depth, frame.camera);
    if (f.points.size() < 1000) continue;
    FindPlanes(&f);
    if (f.planes.empty()) continue;
    FillDropouts(depth, &f.plane_of_pixel);
    planes_ += static_cast<int>(f.planes.size());
    PlaneFrame plane_frame;
    plane_frame.camera = frame.camera;
    plane_frame.planes = static_cast<int>(f.planes.size());
    plane_frame.ideal = IdealFrame(f, depth, frame.camera, &plane_frame.plane_depth);
    plane_frame.plane_of_pixel = std::move(f.plane_of_pixel);
    const PlaneWindowSums ideal_sums(
        plane_frame.ideal, plane_frame.plane_of_pixel, plane_frame.planes);
    plane_frame.interior.assign(depth.depth.size(), 0);
    for (size_t i = 0; i < depth.depth.size(); ++i)
      plane_frame.interior[i] =
          ideal_sums.Complete(plane_frame.ideal, i, plane_frame.plane_of_pixel[i], kBroadRadius);
    real_->Add(depth, plane_frame);
    frames_.push_back(std::move(plane_frame));
  }
}

SensorNoiseBench::~SensorNoiseBench() = default;

int SensorNoiseBench::frames() const { return static_cast<int>(frames_.size()); }

SensorNoiseComparison SensorNoiseBench::Compare(const KinectNoiseOptions& options,
                                                uint64_t seed) const {
  KinectNoiseModel model(options);
  Samples simulated;
  DepthFrame noisy;
  for (size_t frame = 0; frame < frames_.size(); ++frame) {
    model.Apply(frames_[frame].ideal, frames_[frame].camera, seed + frame, &noisy);
    simulated.Add(noisy, frames_[frame]);
  }
  SensorNoiseComparison result;
  result.frames = static_cast<int>(frames_.size());
  result.planes = planes_;
  auto share = [](int64_t part, int64_t whole) {
    return whole > 0 ? static_cast<double>(part) / whole : std::nan("");
  };
  for (int b = 0; b < BinCount(); ++b) {
    NoiseBin bin;
    bin.low_m = kLowM + b * kBinM;
    bin.high_m = bin.low_m + kBinM;
    bin.real_pixels = static_cast<int64_t>(real_->local[b].size());
    bin.simulated_pixels = static_cast<int64_t>(simulated.local[b].size());
    bin.real_sigma_m = RobustSigma(real_->local[b]);
    bin.simulated_sigma_m = RobustSigma(simulated.local[b]);
    bin.real_broad_sigma_m = RobustSigma(real_->broad[b]);
    bin.simulated_broad_sigma_m = RobustSigma(simulated.broad[b]);
    bin.real_missing_share = share(real_->missing[b], real_->plane_pixels[b]);
    bin.simulated_missing_share = share(simulated.missing[b], simulated.plane_pixels[b]);
    result.bins.push_back(bin);
  }
  return result;
}

SensorNoiseComparison CompareSensorNoise(const std::vector<NoiseFrame>& frames,
                                         const KinectNoiseOptions& options,
                                         uint64_t seed) {
  return SensorNoiseBench(frames).Compare(options, seed);
}

namespace {

// Calls visit(weight, log(model sigma / real sigma)) for the 7x7 and 15x15
// sigmas of every bin with kMinFitPixels in both, weighted by the log of the
// pixels.
template <typename Visit>
void ForEachFittedRatio(const SensorNoiseComparison& c, Visit&& visit) {
  for (const NoiseBin& bin : c.bins) {
    if (bin.real_pixels < kMinFitPixels || bin.simulated_pixels < kMinFitPixels) continue;
    const double w = std::log(static_cast<double>(std::min(bin.real_pixels, bin.simulated_pixels)));
    for (const auto& [simulated, real] :
         {std::pair{bin.simulated_sigma_m, bin.real_sigma_m},
          std::pair{bin.simulated_broad_sigma_m, bin.real_broad_sigma_m}}) {
      if (simulated > 0 && real > 0) visit(w, std::log(simulated / real));
    }
  }
}

// The weighted mean of log(model sigma / real sigma) over the fitted bins:
// how much louder the model is (0: as loud).
double MeanLogRatio(const SensorNoiseComparison& c) {
  double sum = 0, weight = 0;
  ForEachFittedRatio(c, [&](double w, double log_ratio) {
    sum += w * log_ratio;
    weight += w;
  });
  return weight > 0 ? sum / weight : 0;
}

}  // namespace

double SensorFitError(const SensorNoiseComparison& c) {
  double error = 0, weight = 0;
  ForEachFittedRatio(c, [&](double w, double log_ratio) {
    error += w * log_ratio * log_ratio;
    weight += w;
  });
  return weight > 0 ? std::sqrt(error / weight) : std::nan("");
}

SensorFit FitSensorNoise(const std::vector<NoiseFrame>& frames,
                         const KinectNoiseOptions& base,
                         uint64_t seed) {
  const SensorNoiseBench bench(frames);
  Require(bench.frames() > 0, "no frame has a plane of 5 % of its pixels to fit the sensor on");
  SensorFit fit;
  fit.options = base;
  fit.before = bench.Compare(base, seed);
  fit.before_error = SensorFitError(fit.before);
  fit.error = std::numeric_limits<double>::infinity();
  Progress progress("sensor fit", kFitRadii.size() * kFitShares.size() * kFitScaleSteps, "models");
  for (int radius : kFitRadii) {
    for (double share : kFitShares) {
      // The sigmas grow about in proportion to the scale (quantisation
      // aside): each step scales by the remaining mean ratio.
      KinectNoiseOptions candidate = base;
      candidate.correlation_radius_px = radius;
      candidate.correlated_share = share;
      candidate.noise_scale = 1.0;
      for (int step = 0; step < kFitScaleSteps; ++step) {
        const SensorNoiseComparison c = bench.Compare(candidate, seed);
        const double error = SensorFitError(c);
        ++fit.candidates;
        if (error < fit.error) {  // ties keep the earlier model
          fit.error = error;
          fit.options = candidate;
          fit.after = c;
        }
        candidate.noise_scale =
            std::clamp(candidate.noise_scale * std::exp(-MeanLogRatio(c)), 0.05, 10.0);
        progress.Advance();
      }
    }
  }
  progress.Finish();
  Require(std::isfinite(fit.error),
          "no depth bin has " + std::to_string(kMinFitPixels) +
              " plane pixels in both the frames and the model to fit the sensor on");
  return fit;
}

std::string SensorNoiseText(const SensorNoiseComparison& c) {
  std::ostringstream text;
  text << c.frames << " frames, " << c.planes
       << " planes (floor and walls): depth noise, robust sigma in mm against a 7x7 and a "
          "15x15 local plane; plane pixels without a return\n"
       << "  depth m   real 7x7 15x15 (pixels)      model 7x7 15x15 (pixels)   model/real 7x7 "
          "15x15   missing real model\n";
  char line[200];
  for (const NoiseBin& bin : c.bins) {
    if (bin.real_pixels == 0 && bin.simulated_pixels == 0) continue;
    std::snprintf(line,
                  sizeof(line),
                  "  %.1f-%.1f   %6.1f %6.1f (%8lld)   %6.1f %6.1f (%8lld)   %5.2f %5.2f   "
                  "%5.1f %% %5.1f %%\n",
                  bin.low_m,
                  bin.high_m,
                  1000 * bin.real_sigma_m,
                  1000 * bin.real_broad_sigma_m,
                  static_cast<long long>(bin.real_pixels),
                  1000 * bin.simulated_sigma_m,
                  1000 * bin.simulated_broad_sigma_m,
                  static_cast<long long>(bin.simulated_pixels),
                  bin.simulated_sigma_m / bin.real_sigma_m,
                  bin.simulated_broad_sigma_m / bin.real_broad_sigma_m,
                  100 * bin.real_missing_share,
                  100 * bin.simulated_missing_share);
    text << line;
  }
  char fit[96];
  std::snprintf(fit, sizeof fit, "  fit error (rms log sigma ratio): %.3f\n", SensorFitError(c));
  return text.str() + fit;
}

namespace {

nlohmann::ordered_json BinsJson(const SensorNoiseComparison& c) {
  nlohmann::ordered_json bins = nlohmann::ordered_json::array();
  auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  for (const NoiseBin& bin : c.bins) {
    bins.push_back({{"low_m", bin.low_m},
                    {"high_m", bin.high_m},
                    {"real_pixels", bin.real_pixels},
                    {"real_sigma_m", number(bin.real_sigma_m)},
                    {"real_broad_sigma_m", number(bin.real_broad_sigma_m)},
                    {"real_missing_share", number(bin.real_missing_share)},
                    {"simulated_pixels", bin.simulated_pixels},
                    {"simulated_sigma_m", number(bin.simulated_sigma_m)},
                    {"simulated_broad_sigma_m", number(bin.simulated_broad_sigma_m)},
                    {"simulated_missing_share", number(bin.simulated_missing_share)}});
  }
  return nlohmann::ordered_json{{"frames", c.frames},
                                {"planes", c.planes},
                                {"fit_error", number(SensorFitError(c))},
                                {"bins", bins}};
}

}  // namespace

std::string SensorNoiseJson(const SensorNoiseComparison& c) { return BinsJson(c).dump(2) + "\n"; }

std::string SensorFitJson(const SensorFit& fit) {
  const nlohmann::ordered_json json{
      {"options",
       {{"noise_scale", fit.options.noise_scale},
        {"correlated_share", fit.options.correlated_share},
        {"correlation_radius_px", fit.options.correlation_radius_px}}},
      {"candidates", fit.candidates},
      {"before_error", fit.before_error},
      {"error", fit.error},
      {"before", BinsJson(fit.before)},
      {"after", BinsJson(fit.after)}};
  return json.dump(2) + "\n";
}

std::vector<NoiseFrame> NoiseFramesOf(const std::string& db_path, int max_frames) {
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadOnly);
  std::vector<NoiseFrame> frames;
  for (int64_t room_id : dataset.RoomIds()) {
    for (const FrameRecord& frame : dataset.ReadRoom(room_id, /*with_images=*/true).frames) {
      if (max_frames > 0 && static_cast<int>(frames.size()) >= max_frames) break;
      const std::string what = db_path + " frame " + std::to_string(frame.id);
      frames.push_back({DecodeDepthPng(frame.depth_noisy_png, what), IntrinsicsOf(frame), what});
    }
  }
  return frames;
}

}  // namespace furn
