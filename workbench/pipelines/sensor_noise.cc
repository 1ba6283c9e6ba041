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
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/pcl_conversion.h"
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
// z = a + b du + c dv over its 7x7 window on the same plane. Real and
// simulated depths get the same estimator, which a slightly misfitted global
// plane or a bowed wall does not bias.
bool LocalResidual(const DepthFrame& frame,
                   const std::vector<int>& plane_of_pixel,
                   size_t i,
                   double* residual) {
  const int u0 = static_cast<int>(i % frame.width), v0 = static_cast<int>(i / frame.width);
  if (u0 < 3 || v0 < 3 || u0 + 3 >= frame.width || v0 + 3 >= frame.height) return false;
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
  Eigen::Vector3d right_side = Eigen::Vector3d::Zero();
  int count = 0;
  for (int dv = -3; dv <= 3; ++dv) {
    for (int du = -3; du <= 3; ++du) {
      if (du == 0 && dv == 0) continue;  // the centre is what is tested
      const size_t j = static_cast<size_t>(v0 + dv) * frame.width + (u0 + du);
      if (plane_of_pixel[j] != plane_of_pixel[i] || frame.depth[j] <= 0) continue;
      const Eigen::Vector3d x(1, du, dv);
      normal_matrix += x * x.transpose();
      right_side += x * frame.depth[j];
      ++count;
    }
  }
  if (count < 30) return false;
  const Eigen::Vector3d fit = normal_matrix.ldlt().solve(right_side);
  *residual = frame.depth[i] - fit.x();
  return true;
}

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

SensorNoiseComparison CompareSensorNoise(const std::vector<NoiseFrame>& frames,
                                         const KinectNoiseOptions& options,
                                         uint64_t seed) {
  const int bin_count = static_cast<int>(std::round((kHighM - kLowM) / kBinM));
  std::vector<std::vector<double>> real(bin_count), simulated(bin_count);
  SensorNoiseComparison result;
  KinectNoiseModel model(options);
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  for (size_t frame = 0; frame < frames.size(); ++frame) {
    const DepthFrame& depth = frames[frame].depth;
    const CameraIntrinsics& camera = frames[frame].camera;
    FramePlanes f = PointsInRange(depth, camera);
    if (f.points.size() < 1000) continue;
    FindPlanes(&f);
    if (f.planes.empty()) continue;
    FillDropouts(depth, &f.plane_of_pixel);
    ++result.frames;
    result.planes += static_cast<int>(f.planes.size());
    std::vector<double> plane_depth;
    const DepthFrame ideal = IdealFrame(f, depth, camera, &plane_depth);
    DepthFrame noisy;
    model.Apply(ideal, camera, seed + frame, &noisy);
    for (size_t i = 0; i < depth.depth.size(); ++i) {
      const double z = plane_depth[i];
      if (z < kLowM || z >= kHighM) continue;
      const int bin = std::min(bin_count - 1, static_cast<int>((z - kLowM) / kBinM));
      double residual = 0;
      if (depth.depth[i] > 0 && LocalResidual(depth, f.plane_of_pixel, i, &residual) &&
          std::abs(residual) <= Band(z))
        real[bin].push_back(residual);
      if (noisy.depth[i] > 0 && LocalResidual(noisy, f.plane_of_pixel, i, &residual) &&
          std::abs(residual) <= Band(z))
        simulated[bin].push_back(residual);
    }
  }
  for (int b = 0; b < bin_count; ++b) {
    NoiseBin bin;
    bin.low_m = kLowM + b * kBinM;
    bin.high_m = bin.low_m + kBinM;
    bin.real_pixels = static_cast<int64_t>(real[b].size());
    bin.simulated_pixels = static_cast<int64_t>(simulated[b].size());
    bin.real_sigma_m = RobustSigma(real[b]);
    bin.simulated_sigma_m = RobustSigma(simulated[b]);
    result.bins.push_back(bin);
  }
  return result;
}

std::string SensorNoiseText(const SensorNoiseComparison& c) {
  std::ostringstream text;
  text << c.frames << " frames, " << c.planes
       << " planes (floor and walls): depth noise, robust sigma in mm\n"
       << "  depth m     real (pixels)        model (pixels)     model/real\n";
  char line[160];
  for (const NoiseBin& bin : c.bins) {
    if (bin.real_pixels == 0 && bin.simulated_pixels == 0) continue;
    std::snprintf(line,
                  sizeof(line),
                  "  %.1f-%.1f   %6.1f (%8lld)   %6.1f (%8lld)   %5.2f\n",
                  bin.low_m,
                  bin.high_m,
                  1000 * bin.real_sigma_m,
                  static_cast<long long>(bin.real_pixels),
                  1000 * bin.simulated_sigma_m,
                  static_cast<long long>(bin.simulated_pixels),
                  bin.simulated_sigma_m / bin.real_sigma_m);
    text << line;
  }
  return text.str();
}

std::string SensorNoiseJson(const SensorNoiseComparison& c) {
  nlohmann::ordered_json bins = nlohmann::ordered_json::array();
  for (const NoiseBin& bin : c.bins) {
    auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
    bins.push_back({{"low_m", bin.low_m},
                    {"high_m", bin.high_m},
                    {"real_pixels", bin.real_pixels},
                    {"real_sigma_m", number(bin.real_sigma_m)},
                    {"simulated_pixels", bin.simulated_pixels},
                    {"simulated_sigma_m", number(bin.simulated_sigma_m)}});
  }
  return nlohmann::ordered_json{{"frames", c.frames}, {"planes", c.planes}, {"bins", bins}}.dump(
             2) +
         "\n";
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
