#include "core/geometry/occupancy.h"

#include <cmath>
#include <limits>
#include <unordered_set>

#include "core/geometry/voxel_key.h"
#include "core/util/error.h"

namespace furn {

OccupancyGrid::OccupancyGrid(const std::vector<Eigen::Vector3f>& points,
                             const Eigen::Vector3f& sensor_origin,
                             double voxel_m)
    : voxel_(static_cast<float>(voxel_m)), inverse_voxel_(1 / voxel_) {
  Require(voxel_m >= 0.005 && voxel_m <= 1,
          "occupancy voxel " + std::to_string(voxel_m) + " m must be in 0.005..1");
  Eigen::Vector3f low = sensor_origin, high = sensor_origin;
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite()) continue;
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  origin_ = low - Eigen::Vector3f::Constant(voxel_);
  const Eigen::Vector3f extent = high - origin_ + Eigen::Vector3f::Constant(voxel_);
  for (int axis = 0; axis < 3; ++axis)
    size_[axis] = std::max(1, static_cast<int>(std::ceil(extent[axis] / voxel_)));
  Require(static_cast<double>(size_.x()) * size_.y() * size_.z() < 4e8,
          "occupancy grid too large (scene extent over voxel size)");
  cells_.assign(static_cast<size_t>(size_.x()) * size_.y() * size_.z(), Occupancy::kUnknown);

  Eigen::Vector3i cell;
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite() && Cell(p, &cell)) cells_[Index(cell)] = Occupancy::kOccupied;
  }
  // Free space: walk each ray from the sensor to the voxel before its end.
  Eigen::Vector3i start;
  Require(Cell(sensor_origin, &start), "occupancy: sensor outside its own grid");
  const Eigen::Vector3f from = (sensor_origin - origin_) / voxel_;  // in voxel units
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite()) continue;
    Eigen::Vector3i end;
    if (!Cell(p, &end)) continue;
    const Eigen::Vector3f direction = (p - origin_) / voxel_ - from;
    Eigen::Vector3i c = start, step;
    Eigen::Vector3f t_max, t_delta;
    for (int axis = 0; axis < 3; ++axis) {
      const float d = direction[axis];
      step[axis] = d > 0 ? 1 : (d < 0 ? -1 : 0);
      if (d == 0) {
        t_max[axis] = t_delta[axis] = std::numeric_limits<float>::infinity();
        continue;
      }
      const float boundary = d > 0 ? c[axis] + 1.0f : static_cast<float>(c[axis]);
      t_max[axis] = (boundary - from[axis]) / d;
      t_delta[axis] = std::abs(1.0f / d);
    }
    // At most the Manhattan distance in voxels; t runs from 0 (sensor) to 1 (point).
    const int steps = (end - start).cwiseAbs().sum();
    for (int k = 0; k < steps && c != end; ++k) {
      Occupancy& state = cells_[Index(c)];
      if (state == Occupancy::kUnknown) state = Occupancy::kFree;
      int axis = 0;
      if (t_max[1] < t_max[axis]) axis = 1;
      if (t_max[2] < t_max[axis]) axis = 2;
      if (t_max[axis] > 1.0f) break;
      c[axis] += step[axis];
      t_max[axis] += t_delta[axis];
    }
  }
}

bool OccupancyGrid::Cell(const Eigen::Vector3f& p, Eigen::Vector3i* cell) const {
  for (int axis = 0; axis < 3; ++axis) {
    const float f = (p[axis] - origin_[axis]) * inverse_voxel_;
    if (!(f >= 0 && f < size_[axis])) return false;
    (*cell)[axis] = static_cast<int>(f);  // f >= 0: truncation is floor
  }
  return true;
}

Occupancy OccupancyGrid::At(const Eigen::Vector3f& p) const {
  Eigen::Vector3i cell;
  return Cell(p, &cell) ? cells_[Index(cell)] : Occupancy::kUnknown;
}

bool OccupancyGrid::OccupiedBeside(const Eigen::Vector3f& p) const {
  Eigen::Vector3i cell;
  if (!Cell(p, &cell)) return false;
  for (int axis = 0; axis < 3; ++axis) {
    for (int step : {-1, 1}) {
      Eigen::Vector3i c = cell;
      c[axis] += step;
      if (c[axis] < 0 || c[axis] >= size_[axis]) continue;
      if (cells_[Index(c)] == Occupancy::kOccupied) return true;
    }
  }
  return false;
}

size_t OccupancyGrid::Count(Occupancy state) const {
  size_t n = 0;
  for (Occupancy c : cells_) n += c == state;
  return n;
}

double VisibilityCounts::Score(double occupied_weight) const {
  const double denominator = occupied * occupied_weight + occluded + free;
  return denominator > 0 ? (occupied * occupied_weight + occluded) / denominator : 0.0;
}

double VisibilityCounts::SeenOccupied() const {
  return occupied + free > 0 ? static_cast<double>(occupied) / (occupied + free) : 0.0;
}

VisibilityCounts CountVisibility(const OccupancyGrid& grid,
                                 const std::vector<Eigen::Vector3f>& model_points,
                                 float min_z) {
  VisibilityCounts counts;
  for (const Eigen::Vector3f& p : model_points) {
    if (p.z() < min_z) continue;
    switch (grid.At(p)) {
      case Occupancy::kOccupied:
        ++counts.occupied;
        break;
      case Occupancy::kUnknown:
        ++counts.occluded;
        break;
      case Occupancy::kFree:
        // A free voxel beside an occupied one: within a voxel of the surface,
        // which pose error and thin parts (legs) make common.
        if (grid.OccupiedBeside(p)) {
          ++counts.occupied;
        } else {
          ++counts.free;
        }
        break;
    }
  }
  return counts;
}

// The voxels taken are bits over the points' bounding box (a room at 5 cm:
// a few hundred kilobytes), a hash set when that box is too large.
std::vector<Eigen::Vector3f> FirstPointPerVoxel(const std::vector<Eigen::Vector3f>& points,
                                                double voxel_m) {
  std::vector<Eigen::Vector3f> kept;
  if (points.empty()) return kept;
  std::vector<Eigen::Vector3i> cells(points.size());
  Eigen::Vector3i low = VoxelCell(points[0], voxel_m), high = low;
  for (size_t i = 0; i < points.size(); ++i) {
    cells[i] = VoxelCell(points[i], voxel_m);
    low = low.cwiseMin(cells[i]);
    high = high.cwiseMax(cells[i]);
  }
  const Eigen::Array3d size = (high - low).cast<double>().array() + 1;
  constexpr double kMaxBits = 1 << 28;  // 32 MB
  constexpr int kKeyField = 1 << 21;    // VoxelKey's field: two cells in range never share a key
  if (size.prod() > kMaxBits || size.maxCoeff() > kKeyField) {
    std::unordered_set<uint64_t> taken;
    for (size_t i = 0; i < points.size(); ++i) {
      if (taken.insert(VoxelKey(cells[i])).second) kept.push_back(points[i]);
    }
    return kept;
  }
  const int64_t nx = static_cast<int64_t>(size.x()), ny = static_cast<int64_t>(size.y());
  std::vector<uint64_t> taken((static_cast<size_t>(size.prod()) + 63) / 64, 0);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3i c = cells[i] - low;
    const uint64_t bit = static_cast<uint64_t>((c.z() * ny + c.y()) * nx + c.x());
    uint64_t& word = taken[bit / 64];
    const uint64_t mask = uint64_t{1} << (bit % 64);
    if (word & mask) continue;
    word |= mask;
    kept.push_back(points[i]);
  }
  return kept;
}

}  // namespace furn
