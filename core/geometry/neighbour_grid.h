// Fixed-radius neighbour search on a uniform grid of cubic cells (edge = the
// largest radius asked for): a query visits the 27 cells around its point.
// Several times faster than a kd-tree for the dense, evenly sampled clouds
// preprocessing makes (1.5 cm voxels, 3 to 5 cm radii), and shared by the
// normal fit and region growing. Visits are in a fixed order (cell by cell,
// points by index), so results are deterministic.
//
//   NeighbourGrid grid(cloud.points, 0.05f);
//   grid.ForEachWithin(p, 0.05f, [&](int j, float squared_distance) { ... });
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/geometry/voxel_key.h"

namespace furn {

class NeighbourGrid {
 public:
  // `points` must outlive the grid; cell > 0.
  NeighbourGrid(const std::vector<Eigen::Vector3f>& points, float cell);

  // Calls visit(j, squared distance) for every point j within `radius`
  // (<= the cell edge) of p, p itself included when it is one of the points.
  // The same for the grid's own point i, without hashing: each occupied
  // cell keeps its neighbouring cells (the form for loops over all points).
  template <class Visit>
  void ForEachNeighbourOf(int i, float radius, Visit&& visit) const {
    ForEachNeighbourOf(
        i, radius, [](int) { return false; }, visit);
  }

  // The same, skipping the cells for which skip_cell(cell index) is true
  // (a caller that knows a cell holds nothing more for it).
  template <class Skip, class Visit>
  void ForEachNeighbourOf(int i, float radius, Skip&& skip_cell, Visit&& visit) const {
    ForEachNeighbourOf(
        i, radius, skip_cell, [](int) { return false; }, visit);
  }

  // The same, skipping also the points for which skip_point(j) is true
  // before their distance is computed (region growing: points already
  // taken).
  template <class SkipCell, class SkipPoint, class Visit>
  void ForEachNeighbourOf(
      int i, float radius, SkipCell&& skip_cell, SkipPoint&& skip_point, Visit&& visit) const {
    VisitAround(
        points_[i],
        cell_of_point_[i],
        radius,
        skip_cell,
        [&](int k) { return skip_point(order_[k]); },
        [&](int k, float d2) { visit(order_[k], d2); });
  }

  // The same in slots: the points numbered in the grid's order (a cell's
  // points side by side, by index within a cell), for callers that keep
  // their own per-point data in that order and so read it in sequence
  // (region growing). skip_slot(k) and visit(k, squared distance) get
  // slots; the visits come in the same order as ForEachNeighbourOf's.
  template <class SkipCell, class SkipSlot, class Visit>
  void ForEachNeighbourOfSlot(
      int slot, float radius, SkipCell&& skip_cell, SkipSlot&& skip_slot, Visit&& visit) const {
    VisitAround(
        ordered_points_[slot], cell_of_point_[order_[slot]], radius, skip_cell, skip_slot, visit);
  }

  // The occupied cells, 0..NumCells(). Slots: the point in slot k (0..size),
  // and a cell's slots [first, end).
  int NumCells() const { return static_cast<int>(ranges_.size()); }
  int PointOfSlot(int k) const { return order_[k]; }
  std::pair<int, int> SlotsOfCell(int cell) const { return ranges_[cell]; }

  template <class Visit>
  void ForEachWithin(const Eigen::Vector3f& p, float radius, Visit&& visit) const {
    const float radius2 = radius * radius;
    const Eigen::Vector3i centre = CellOf(p);
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int cell = FindCell(centre + Eigen::Vector3i(dx, dy, dz));
          if (cell < 0) continue;
          const auto& [begin, end] = ranges_[cell];
          for (int k = begin; k < end; ++k) {
            const float d2 = (ordered_points_[k] - p).squaredNorm();
            if (d2 <= radius2) visit(order_[k], d2);
          }
        }
      }
    }
  }

 private:
  // The slots within `radius` of p, a point of `cell`, cell by cell.
  template <class SkipCell, class SkipSlot, class Visit>
  void VisitAround(const Eigen::Vector3f& p,
                   int cell,
                   float radius,
                   SkipCell&& skip_cell,
                   SkipSlot&& skip_slot,
                   Visit&& visit) const {
    const float radius2 = radius * radius;
    for (int n = neighbour_begin_[cell]; n < neighbour_begin_[cell + 1]; ++n) {
      if (skip_cell(neighbour_cells_[n])) continue;
      const auto& [begin, end] = ranges_[neighbour_cells_[n]];
      for (int k = begin; k < end; ++k) {
        if (skip_slot(k)) continue;
        const float d2 = (ordered_points_[k] - p).squaredNorm();
        if (d2 <= radius2) visit(k, d2);
      }
    }
  }

  Eigen::Vector3i CellOf(const Eigen::Vector3f& p) const {
    return Eigen::Vector3i(FloorToInt(p.x() * inverse_cell_),
                           FloorToInt(p.y() * inverse_cell_),
                           FloorToInt(p.z() * inverse_cell_));
  }
  static uint64_t Key(const Eigen::Vector3i& c) { return VoxelKey(c); }
  // The index of an occupied cell, or -1.
  int FindCell(const Eigen::Vector3i& cell) const;

  const std::vector<Eigen::Vector3f>& points_;
  float inverse_cell_;
  std::vector<int> order_;                       // point indices, grouped by cell
  std::vector<Eigen::Vector3f> ordered_points_;  // points_[order_[k]]: a cell's points side by side
  std::vector<std::pair<int, int>> ranges_;      // per occupied cell: [begin, end) in order_
  std::vector<uint64_t> cell_keys_;              // per cell, ascending: its key
  std::vector<int> cell_of_point_;               // index into ranges_
  std::vector<int> neighbour_begin_;             // per cell, into neighbour_cells_ (+1 sentinel)
  std::vector<int> neighbour_cells_;             // occupied cells among the 27 around each
};

}  // namespace furn
