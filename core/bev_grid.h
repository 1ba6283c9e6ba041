// The bird's-eye-view grid of the learned vote stage (issue 30): a scan's
// points in the world frame (floor at z = 0), rasterised into cells on the
// floor plane, aligned with the camera's horizontal view direction.
//
// The grid's frame: the origin under the sensor, u along the horizontal view
// direction (forward), v to its left. Row r covers u in [r, r + 1) * cell,
// column c covers v in [c - cols / 2, c + 1 - cols / 2) * cell. Channels:
//
//   0      floor points (z below the floor band)       log(1 + count) / 4
//   1..5   points per height slice (kSliceTopsM)        log(1 + count) / 4
//   6      the highest point's height                  metres / 2
//   7      seen: the cell lies nearer the sensor than the farthest return
//          of its bearing (free or occupied, not behind everything seen)
//
// The same function rasterises training frames and scans to detect, so the
// network sees one representation. Targets (what the network should output)
// for labelled objects are made here too: per class a Gaussian-splatted
// centre heat map, and at each object's centre cell its sub-cell offset,
// log footprint size and yaw (cos, sin of symmetry x yaw) in the grid frame.
//
//   const BevFrame frame = BevFrameOf(world_from_camera, spec);
//   const BevImage image = RasteriseBev(world_points, frame, spec);
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <vector>

#include "core/furniture_class.h"

namespace furn {

inline constexpr int kBevChannels = 8;
inline constexpr std::array<float, 5> kSliceTopsM = {0.25f, 0.5f, 0.8f, 1.1f, 1.8f};

// Output channels per cell: a heat map per class, then offset (2), log size
// (2: width, depth) and yaw (2: cos, sin of symmetry x yaw).
inline constexpr int kBevClasses = static_cast<int>(kAllClasses.size());
inline constexpr int kBevOutputs = kBevClasses + 6;

struct BevGridSpec {
  double cell_m = 0.05;
  int rows = 72;  // forward: rows x cell (3.6 m); a multiple of 8 (the network halves it 3 times)
  int cols = 96;  // lateral: cols x cell, centred on the view direction
  double floor_band_m = 0.03;

  // Throws InputError naming the field and the rule.
  void Check() const;
  bool operator==(const BevGridSpec& other) const;
};

// Where the grid lies in the world: the sensor's xy and the horizontal view
// direction (unit).
struct BevFrame {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  Eigen::Vector2d forward = Eigen::Vector2d::UnitX();
  double heading = 0;  // atan2 of forward

  Eigen::Vector2d Left() const { return {-forward.y(), forward.x()}; }
  // World xy -> continuous cell coordinates (row, col); cell (r, c) spans
  // [r, r + 1) x [c, c + 1).
  Eigen::Vector2d CellOf(const Eigen::Vector2d& world_xy, const BevGridSpec& spec) const;
  Eigen::Vector2d WorldOf(const Eigen::Vector2d& cell, const BevGridSpec& spec) const;
};

// The frame of a camera pose (z up, floor at z = 0). A camera looking
// straight down has no horizontal direction: its image's up (-y) is used.
BevFrame BevFrameOf(const Eigen::Isometry3d& world_from_camera);

// kBevChannels x rows x cols, channel-major, row-major within a channel.
struct BevImage {
  BevGridSpec spec;
  BevFrame frame;
  std::vector<float> values;

  float& At(int channel, int row, int col) {
    return values[(static_cast<size_t>(channel) * spec.rows + row) * spec.cols + col];
  }
  float At(int channel, int row, int col) const {
    return values[(static_cast<size_t>(channel) * spec.rows + row) * spec.cols + col];
  }
  // The image mirrored left-right (v -> -v), for augmentation.
  BevImage Mirrored() const;
};

// Rasterises world points (non-finite ones skipped) seen from `sensor`.
BevImage RasteriseBev(const std::vector<Eigen::Vector3f>& world_points,
                      const Eigen::Vector3f& sensor,
                      const BevFrame& frame,
                      const BevGridSpec& spec);

// A scan as both training and detection rasterise it: the finite camera-frame
// points within `max_range_m` of the sensor, in the world frame, in the grid
// of the camera's pose.
BevImage RasteriseScan(const std::vector<Eigen::Vector3f>& camera_points,
                       const Eigen::Isometry3d& world_from_camera,
                       double max_range_m,
                       const BevGridSpec& spec);

// The rotational symmetry the yaw is learnt modulo: 2 for tables (a
// rectangle's two ends look alike), 1 for the rest (a front).
int BevYawSymmetry(FurnitureClass furniture_class);

// One labelled object as a target: its footprint centre (world xy), yaw,
// footprint width (along its x) and depth (m).
struct BevObject {
  FurnitureClass furniture_class = FurnitureClass::kChair;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double yaw = 0;
  double width = 0, depth = 0;
};

// The object mirrored as BevImage::Mirrored mirrors the image (v -> -v in
// the grid's frame). A piece's front faces its -y (docs/cad-models.md), and
// furniture is mirror-symmetric about that axis, so the mirrored piece is the
// piece turned to yaw' = heading + pi - (yaw - heading).
BevObject MirroredObject(const BevObject& object, const BevFrame& frame);

// kBevOutputs x rows x cols: heat (0..1, 1 at each centre cell), and at the
// centre cells the regression targets; `mask` (rows x cols) is 1 where the
// regressions count.
struct BevTargets {
  std::vector<float> values;
  std::vector<float> mask;
  int objects = 0;  // inside the grid
};

BevTargets BevTargetsOf(const std::vector<BevObject>& objects,
                        const BevFrame& frame,
                        const BevGridSpec& spec);

// The Gaussian's sigma (cells) of an object's centre splat.
double BevSplatSigma(double width_m, double depth_m, const BevGridSpec& spec);

}  // namespace furn
