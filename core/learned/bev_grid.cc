#include "core/learned/bev_grid.h"

#include <algorithm>
#include <cmath>

#include "core/util/angles.h"
#include "core/util/error.h"

namespace furn {
namespace {

// Bearings of the "seen" channel: the farthest return per bearing bin.
constexpr int kBearingBins = 720;  // 0.5 degree

float LogCount(float count) { return std::log1p(count) / 4.0f; }

// atan(x) for |x| <= 1 within 0.0015 rad (Rajan, Wang, Inkol and Joyal,
// "Efficient approximations for the arctangent function", 2006): a sixth of
// a bearing bin, so the bin it gives is the true one or a neighbour.
double RoughAtan(double x) {
  return M_PI / 4 * x - x * (std::abs(x) - 1) * (0.2447 + 0.0663 * std::abs(x));
}

double RoughAtan2(double v, double u) {
  const double au = std::abs(u), av = std::abs(v);
  if (au == 0 && av == 0) return 0;
  double angle = au >= av ? RoughAtan(av / au) : M_PI / 2 - RoughAtan(au / av);
  if (u < 0) angle = M_PI - angle;
  return v < 0 ? -angle : angle;
}

// The directions where the bins begin (bin b spans [-pi + b w, -pi + (b + 1) w)).
struct BinEdges {
  double cos[kBearingBins + 1], sin[kBearingBins + 1];
  BinEdges() {
    for (int b = 0; b <= kBearingBins; ++b) {
      const double angle = -M_PI + 2 * M_PI * b / kBearingBins;
      cos[b] = std::cos(angle);
      sin[b] = std::sin(angle);
    }
  }
  // Whether (u, v) lies counter-clockwise of edge b (within half a turn).
  bool After(int b, double u, double v) const { return cos[b] * v - sin[b] * u >= 0; }
};

// The bearing's bin, -pi..pi in kBearingBins: the rough arctangent's bin,
// moved to the neighbour whose edges hold the point (no trigonometry per
// point; the bin of atan2 but where rounding decides at an edge).
int BearingBin(double u, double v) {
  static const BinEdges edges;
  int bin = static_cast<int>((RoughAtan2(v, u) + M_PI) / (2 * M_PI) * kBearingBins);
  bin = std::clamp(bin, 0, kBearingBins - 1);
  while (bin > 0 && !edges.After(bin, u, v)) --bin;
  while (bin < kBearingBins - 1 && edges.After(bin + 1, u, v)) ++bin;
  return bin;
}

}  // namespace

void BevGridSpec::Check() const {
  Require(cell_m >= 0.01 && cell_m <= 0.5,
          "BEV cell " + std::to_string(cell_m) + " m must be in 0.01..0.5");
  Require(rows >= 8 && rows <= 1024 && rows % 8 == 0,
          "BEV rows " + std::to_string(rows) + " must be a multiple of 8 in 8..1024");
  Require(cols >= 8 && cols <= 1024 && cols % 8 == 0,
          "BEV cols " + std::to_string(cols) + " must be a multiple of 8 in 8..1024");
  Require(floor_band_m >= 0 && floor_band_m < kSliceTopsM[0],
          "BEV floor band must be in 0..0.25 m");
}

bool BevGridSpec::operator==(const BevGridSpec& other) const {
  return cell_m == other.cell_m && rows == other.rows && cols == other.cols &&
         floor_band_m == other.floor_band_m;
}

Eigen::Vector2d BevFrame::CellOf(const Eigen::Vector2d& world_xy, const BevGridSpec& spec) const {
  const Eigen::Vector2d d = world_xy - origin;
  return {d.dot(forward) / spec.cell_m, d.dot(Left()) / spec.cell_m + spec.cols / 2.0};
}

Eigen::Vector2d BevFrame::WorldOf(const Eigen::Vector2d& cell, const BevGridSpec& spec) const {
  return origin + forward * (cell.x() * spec.cell_m) +
         Left() * ((cell.y() - spec.cols / 2.0) * spec.cell_m);
}

BevFrame BevFrameOf(const Eigen::Isometry3d& world_from_camera) {
  BevFrame frame;
  frame.origin = world_from_camera.translation().head<2>();
  Eigen::Vector2d forward = (world_from_camera.linear() * Eigen::Vector3d::UnitZ()).head<2>();
  if (forward.norm() < 1e-6)  // looking straight down: the image's up
    forward = (world_from_camera.linear() * -Eigen::Vector3d::UnitY()).head<2>();
  if (forward.norm() < 1e-9) forward = Eigen::Vector2d::UnitX();
  frame.forward = forward.normalized();
  frame.heading = std::atan2(frame.forward.y(), frame.forward.x());
  return frame;
}

BevImage BevImage::Mirrored() const {
  BevImage out = *this;
  for (int k = 0; k < kBevChannels; ++k) {
    for (int r = 0; r < spec.rows; ++r) {
      for (int c = 0; c < spec.cols; ++c) out.At(k, r, c) = At(k, r, spec.cols - 1 - c);
    }
  }
  return out;
}

bool BevImage::Occupied(int row, int col) const {
  for (int k = 1; k <= static_cast<int>(kSliceTopsM.size()); ++k) {
    if (At(k, row, col) > 0) return true;
  }
  return false;
}

BevImage RasteriseBev(const std::vector<Eigen::Vector3f>& world_points,
                      const Eigen::Vector3f& sensor,
                      const BevFrame& frame,
                      const BevGridSpec& spec) {
  BevImage image;
  image.spec = spec;
  image.frame = frame;
  image.values.assign(static_cast<size_t>(kBevChannels) * spec.rows * spec.cols, 0.0f);
  std::vector<double> farthest2(kBearingBins, 0.0);  // squared
  const Eigen::Vector2d left = frame.Left();
  const Eigen::Vector2d sensor_xy = sensor.head<2>().cast<double>();
  for (const Eigen::Vector3f& p : world_points) {
    if (!p.allFinite()) continue;
    const Eigen::Vector2d from_sensor = p.head<2>().cast<double>() - sensor_xy;
    const double u = from_sensor.dot(frame.forward), v = from_sensor.dot(left);
    const int bin = BearingBin(u, v);
    farthest2[bin] = std::max(farthest2[bin], u * u + v * v);
    const Eigen::Vector2d cell = frame.CellOf(p.head<2>().cast<double>(), spec);
    const int row = static_cast<int>(std::floor(cell.x()));
    const int col = static_cast<int>(std::floor(cell.y()));
    if (row < 0 || row >= spec.rows || col < 0 || col >= spec.cols) continue;
    if (p.z() < spec.floor_band_m) {
      image.At(0, row, col) += 1.0f;
      continue;
    }
    const auto slice = std::upper_bound(kSliceTopsM.begin(), kSliceTopsM.end(), p.z());
    if (slice != kSliceTopsM.end())
      image.At(1 + static_cast<int>(slice - kSliceTopsM.begin()), row, col) += 1.0f;
    image.At(kBevTopChannel, row, col) =
        std::max(image.At(kBevTopChannel, row, col), std::min(p.z(), 4.0f) / 2.0f);
  }
  for (int k = 0; k < kBevTopChannel; ++k) {  // the counts
    for (int r = 0; r < spec.rows; ++r) {
      for (int c = 0; c < spec.cols; ++c) image.At(k, r, c) = LogCount(image.At(k, r, c));
    }
  }
  // Seen: the cell's centre is nearer than the farthest return of its bearing.
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      const Eigen::Vector2d d = frame.WorldOf({r + 0.5, c + 0.5}, spec) - sensor_xy;
      const double u = d.dot(frame.forward), v = d.dot(left);
      image.At(kBevSeenChannel, r, c) = u * u + v * v < farthest2[BearingBin(u, v)] ? 1.0f : 0.0f;
    }
  }
  return image;
}

BevImage RasteriseScan(const std::vector<Eigen::Vector3f>& camera_points,
                       const Eigen::Isometry3d& world_from_camera,
                       double max_range_m,
                       const BevGridSpec& spec) {
  const Eigen::Matrix3f rotation = world_from_camera.linear().cast<float>();
  const Eigen::Vector3f translation = world_from_camera.translation().cast<float>();
  const float max_range2 = static_cast<float>(max_range_m * max_range_m);
  std::vector<Eigen::Vector3f> world;
  world.reserve(camera_points.size());
  for (const Eigen::Vector3f& p : camera_points) {
    if (p.allFinite() && p.squaredNorm() > 0 && p.squaredNorm() <= max_range2)
      world.push_back(rotation * p + translation);
  }
  return RasteriseBev(world, translation, BevFrameOf(world_from_camera), spec);
}

BevObject MirroredObject(const BevObject& object, const BevFrame& frame) {
  BevObject mirrored = object;
  const Eigen::Vector2d d = object.Centre() - frame.origin;
  mirrored.SetCentre(frame.origin + frame.forward * d.dot(frame.forward) -
                     frame.Left() * d.dot(frame.Left()));
  mirrored.yaw = WrapAngle(frame.heading + M_PI - (object.yaw - frame.heading));
  return mirrored;
}

}  // namespace furn
