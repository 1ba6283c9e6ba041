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

class OccupancyGrid {
 public:
  // Points (world frame) and the sensor position; voxel edge in metres.
  OccupancyGrid(const std::vector<Eigen::Vector3f>& points,
                const Eigen::Vector3f& sensor_origin,
                double voxel_m);

  Occupancy At(const Eigen::Vector3f& p) const;  // kUnknown outside the grid
  double voxel_m() const { return voxel_; }
  // Voxels per state, for reports and tests.
  size_t Count(Occupancy state) const;

 private:
  bool Cell(const Eigen::Vector3f& p, Eigen::Vector3i* cell) const;
  size_t Index(const Eigen::Vector3i& c) const {
    return (static_cast<size_t>(c.z()) * size_.y() + c.y()) * size_.x() + c.x();
  }

  float voxel_;
  Eigen::Vector3f origin_;  // corner of voxel (0, 0, 0)
  Eigen::Vector3i size_;
  std::vector<Occupancy> cells_;
};

// SPEC.md §8.7: vs = (occupied * w + occluded) / (occupied * w + occluded + free)
// over the given model points (world frame); points below `min_z` are skipped
// (the floor is removed from the scene). 0 when no point counts.
double VisibilityScore(const OccupancyGrid& grid,
                       const std::vector<Eigen::Vector3f>& model_points,
                       double occupied_weight,
                       float min_z);

}  // namespace furn
