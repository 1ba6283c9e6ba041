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
constexpr double kBinsPerRadian = kBearingBins / (2 * M_PI);

int RoughBin(double u, double v) {
  return std::clamp(
      static_cast<int>((RoughAtan2(v, u) + M_PI) * kBinsPerRadian), 0, kBearingBins - 1);
}

int ExactBin(const BinEdges& edges, int bin, double u, double v) {
  while (bin > 0 && !edges.After(bin, u, v)) --bin;
  while (bin < kBearingBins - 1 && edges.After(bin + 1, u, v)) ++bin;
  return bin;
}

const BinEdges& Edges() {
  static const BinEdges edges;
  return edges;
}

int BearingBin(double u, double v) { return ExactBin(Edges(), RoughBin(u, v), u, v); }

// log(1 + count) / 4 of the small counts, looked up (the same values).
struct LogCounts {
  static constexpr int kSize = 4096;
  float value[kSize];
  LogCounts() {
    for (int count = 0; count < kSize; ++count) value[count] = LogCount(static_cast<float>(count));
  }
  float operator()(float count) const {
    return count < kSize ? value[static_cast<int>(count)] : LogCount(count);
  }
};

// One image built point by point (world frame): the counts, the highest
// point and each bearing's farthest return, then the channels finished.
class BevRasteriser {
 public:
  BevRasteriser(const Eigen::Vector3f& sensor, const BevFrame& frame, const BevGridSpec& spec)
      : edges_(Edges()),
        left_(frame.Left()),
        sensor_xy_(sensor.head<2>().cast<double>()),
        farthest2_(kBearingBins, 0.0) {
    image_.spec = spec;
    image_.frame = frame;
    image_.values.assign(static_cast<size_t>(kBevChannels) * spec.rows * spec.cols, 0.0f);
  }

  void Add(const Eigen::Vector3f& p) {
    const BevFrame& frame = image_.frame;
    const BevGridSpec& spec = image_.spec;
    const Eigen::Vector2d xy = p.head<2>().cast<double>();
    const Eigen::Vector2d from_sensor = xy - sensor_xy_;
    const double u = from_sensor.dot(frame.forward), v = from_sensor.dot(left_);
    const double range2 = u * u + v * v;
    // The exact bin is the rough one or a neighbour (the rough arctangent
    // errs by a sixth of a bin): a point no farther than all three cannot
    // raise any of them.
    const int rough = RoughBin(u, v);
    if (rough == 0 || rough == kBearingBins - 1 ||
        range2 > std::min({farthest2_[rough - 1], farthest2_[rough], farthest2_[rough + 1]})) {
      const int bin = ExactBin(edges_, rough, u, v);
      farthest2_[bin] = std::max(farthest2_[bin], range2);
    }
    const Eigen::Vector2d d = xy - frame.origin;  // BevFrame::CellOf
    const int row = static_cast<int>(std::floor(d.dot(frame.forward) / spec.cell_m));
    const int col = static_cast<int>(std::floor(d.dot(left_) / spec.cell_m + spec.cols / 2.0));
    if (row < 0 || row >= spec.rows || col < 0 || col >= spec.cols) return;
    if (p.z() < spec.floor_band_m) {
      image_.At(0, row, col) += 1.0f;
      return;
    }
    const auto slice = std::upper_bound(kSliceTopsM.begin(), kSliceTopsM.end(), p.z());
    if (slice != kSliceTopsM.end())
      image_.At(1 + static_cast<int>(slice - kSliceTopsM.begin()), row, col) += 1.0f;
    float& top = image_.At(kBevTopChannel, row, col);
    top = std::max(top, std::min(p.z(), 4.0f) / 2.0f);
  }

  BevImage Finish() {
    static const LogCounts log_counts;
    const BevGridSpec& spec = image_.spec;
    const BevFrame& frame = image_.frame;
    const size_t cells = static_cast<size_t>(spec.rows) * spec.cols;
    for (size_t i = 0; i < kBevTopChannel * cells; ++i)  // the counts
      image_.values[i] = log_counts(image_.values[i]);
    // Seen: the cell's centre is nearer than the farthest return of its bearing.
    for (int r = 0; r < spec.rows; ++r) {
      for (int c = 0; c < spec.cols; ++c) {
        const Eigen::Vector2d d = frame.WorldOf({r + 0.5, c + 0.5}, spec) - sensor_xy_;
        const double u = d.dot(frame.forward), v = d.dot(left_);
        image_.At(kBevSeenChannel, r, c) =
            u * u + v * v < farthest2_[BearingBin(u, v)] ? 1.0f : 0.0f;
      }
    }
    return std::move(image_);
  }

 private:
  const BinEdges& edges_;
  Eigen::Vector2d left_, sensor_xy_;
  std::vector<double> farthest2_;  // squared
  BevImage image_;
};

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
  BevRasteriser rasteriser(sensor, frame, spec);
  for (const Eigen::Vector3f& p : world_points) {
    if (p.allFinite()) rasteriser.Add(p);
  }
  return rasteriser.Finish();
}

BevImage RasteriseScan(const std::vector<Eigen::Vector3f>& camera_points,
                       const Eigen::Isometry3d& world_from_camera,
                       double max_range_m,
                       const BevGridSpec& spec) {
  const Eigen::Matrix3f rotation = world_from_camera.linear().cast<float>();
  const Eigen::Vector3f translation = world_from_camera.translation().cast<float>();
  const float max_range2 = static_cast<float>(max_range_m * max_range_m);
  // Each point straight into the image (no copy of the scan in the world).
  BevRasteriser rasteriser(translation, BevFrameOf(world_from_camera), spec);
  for (const Eigen::Vector3f& p : camera_points) {
    if (!p.allFinite()) continue;
    const float range2 = p.squaredNorm();
    if (range2 > 0 && range2 <= max_range2) {
      const Eigen::Vector3f world = rotation * p + translation;
      if (world.allFinite()) rasteriser.Add(world);
    }
  }
  return rasteriser.Finish();
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
