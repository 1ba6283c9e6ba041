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
// network sees one representation. What the network should output for
// labelled objects, and how its output becomes detections, is the box
// coder's (bev_box_coder.h).
//
//   const BevFrame frame = BevFrameOf(world_from_camera, spec);
//   const BevImage image = RasteriseBev(world_points, frame, spec);
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <vector>

#include "core/learned/bev_channels.h"
#include "core/model/furniture_box.h"

namespace furn {

inline constexpr int kBevChannels = 8;
inline constexpr std::array<float, 5> kSliceTopsM = {0.25f, 0.5f, 0.8f, 1.1f, 1.8f};
inline constexpr int kBevTopChannel = 6;   // the highest point's height / 2 (m)
inline constexpr int kBevSeenChannel = 7;  // 1: nearer than its bearing's farthest return

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
  // Whether anything above the floor band was seen in the cell (a point in a
  // height slice): the cells whose votes count.
  bool Occupied(int row, int col) const;
};

// The vote network's output for one image: bev_channels::CountOf(edge_votes)
// x rows x cols, channel-major, the heat and membership channels through a sigmoid
// (0..1), the rest as regressed.
struct BevOutput {
  BevGridSpec spec;
  std::vector<float> values;
  bool dense_votes = false;  // every cell's vote was trained (BevCoderOptions)
  bool edge_votes = false;   // the edge channels are there (bev_channels::kEdges)
  float At(int channel, int row, int col) const {
    return values[(static_cast<size_t>(channel) * spec.rows + row) * spec.cols + col];
  }
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

// One labelled object: its box (world frame) and class. An object seen too little to be a
// target (target false) is neither rewarded nor punished: the loss ignores
// the heat around it.
struct BevObject : FurnitureBox {
  FurnitureClass furniture_class = FurnitureClass::kChair;
  bool target = true;
};

// The object mirrored as BevImage::Mirrored mirrors the image (v -> -v in
// the grid's frame). A piece's front faces its -y (docs/cad-models.md), and
// furniture is mirror-symmetric about that axis, so the mirrored piece is the
// piece turned to yaw' = heading + pi - (yaw - heading).
BevObject MirroredObject(const BevObject& object, const BevFrame& frame);

}  // namespace furn
