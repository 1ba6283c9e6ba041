// Occupancy of a scene as the sensor saw it (SPEC.md §8.7): a voxel grid where
// each measured point's voxel is occupied, the voxels its ray crossed on the
// way from the sensor are free, and the rest is unknown (occluded or out of
// view). Rays are traversed voxel by voxel (Amanatides and Woo).
//
//   OccupancyGrid grid(points, sensor_origin, 0.05);
//   if (grid.At(p) == Occupancy::kFree) ...
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace furn {

enum class Occupancy : uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

// The first point of each voxel of `voxel_m` (VoxelKey's cells), in the
// points' order: the ray ends an occupancy grid needs (points must be
// finite).
std::vector<Eigen::Vector3f> FirstPointPerVoxel(const std::vector<Eigen::Vector3f>& points,
                                                double voxel_m);

class OccupancyGrid {
 public:
  // Points (world frame) and the sensor position; voxel edge in metres.
  OccupancyGrid(const std::vector<Eigen::Vector3f>& points,
                const Eigen::Vector3f& sensor_origin,
                double voxel_m);

  Occupancy At(const Eigen::Vector3f& p) const;  // kUnknown outside the grid
  // Whether one of the six voxels sharing a face with p's is occupied.
  bool OccupiedBeside(const Eigen::Vector3f& p) const;
  double voxel_m() const { return voxel_; }
  // Voxels per state, for reports and tests.
  size_t Count(Occupancy state) const;

 private:
  bool Cell(const Eigen::Vector3f& p, Eigen::Vector3i* cell) const;
  size_t Index(const Eigen::Vector3i& c) const {
    return (static_cast<size_t>(c.z()) * size_.y() + c.y()) * size_.x() + c.x();
  }

  float voxel_;
  float inverse_voxel_;
  Eigen::Vector3f origin_;  // corner of voxel (0, 0, 0)
  Eigen::Vector3i size_;
  std::vector<Occupancy> cells_;
};

// How the posed model's points (world frame) fall in the grid; points below
// `min_z` are skipped (the floor is removed from the scene). A point in a
// free voxel next to an occupied one counts as occupied (a voxel of slack).
struct VisibilityCounts {
  int occupied = 0, occluded = 0, free = 0;

  // SPEC.md §8.7: vs = (occupied w + occluded) / (occupied w + occluded + free);
  // 0 when no point counts.
  double Score(double occupied_weight) const;
  // Of the points the sensor could have seen (not occluded), the share it did.
  double SeenOccupied() const;
};
VisibilityCounts CountVisibility(const OccupancyGrid& grid,
                                 const std::vector<Eigen::Vector3f>& model_points,
                                 float min_z);

}  // namespace furn
