#include "core/geometry/neighbour_grid.h"

#include <algorithm>
#include <array>

#include "core/util/error.h"

namespace furn {

NeighbourGrid::NeighbourGrid(const std::vector<Eigen::Vector3f>& points, float cell)
    : points_(points), inverse_cell_(1.0f / cell) {
  Require(cell > 0, "neighbour grid cell must be > 0");
  // Points by cell key, ties by index: the order a stable sort by key gives.
  std::vector<std::pair<uint64_t, int>> keyed(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    keyed[i] = {Key(CellOf(points[i])), static_cast<int>(i)};
  std::sort(keyed.begin(), keyed.end());
  order_.resize(points.size());
  ordered_points_.resize(points.size());
  cell_of_point_.resize(points.size());
  for (size_t k = 0; k < keyed.size();) {
    size_t end = k + 1;
    while (end < keyed.size() && keyed[end].first == keyed[k].first) ++end;
    const int cell = static_cast<int>(ranges_.size());
    ranges_.emplace_back(static_cast<int>(k), static_cast<int>(end));
    cell_keys_.push_back(keyed[k].first);
    for (size_t m = k; m < end; ++m) {
      order_[m] = keyed[m].second;
      ordered_points_[m] = points[keyed[m].second];
      cell_of_point_[keyed[m].second] = cell;
    }
    k = end;
  }
  // A cell's occupied neighbours in the order dz, dy, dx (outer to inner).
  // Within the grid's range a neighbour's key is the cell's key plus a
  // fixed step (VoxelKey packs x, y, z into separate bit fields, z lowest),
  // so the three cells of a (dx, dy) column are consecutive keys, and as
  // the cells go up in key each column's first key does too: one forward
  // cursor per column.
  constexpr int kColumns = 9;
  std::array<uint64_t, kColumns> step;  // from a cell's key to its column's lowest (dz = -1)
  std::array<size_t, kColumns> cursor{};
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx)
      step[(dy + 1) * 3 + (dx + 1)] =
          Key(Eigen::Vector3i(dx, dy, -1)) - Key(Eigen::Vector3i::Zero());
  }
  const size_t cells = cell_keys_.size();
  neighbour_begin_.reserve(cells + 1);
  std::array<int, 27> found;  // [dz + 1][dy + 1][dx + 1], -1 when empty
  for (size_t c = 0; c < cells; ++c) {
    neighbour_begin_.push_back(static_cast<int>(neighbour_cells_.size()));
    found.fill(-1);
    for (int column = 0; column < kColumns; ++column) {
      const uint64_t low = cell_keys_[c] + step[column];
      size_t& at = cursor[column];
      while (at < cells && cell_keys_[at] < low) ++at;
      for (size_t k = at; k < cells && k < at + 3 && cell_keys_[k] <= low + 2; ++k)
        found[static_cast<int>(cell_keys_[k] - low) * 9 + column] = static_cast<int>(k);
    }
    for (int n : found) {
      if (n >= 0) neighbour_cells_.push_back(n);
    }
  }
  neighbour_begin_.push_back(static_cast<int>(neighbour_cells_.size()));
}

int NeighbourGrid::FindCell(const Eigen::Vector3i& cell) const {
  const uint64_t key = Key(cell);
  const auto it = std::lower_bound(cell_keys_.begin(), cell_keys_.end(), key);
  return it != cell_keys_.end() && *it == key ? static_cast<int>(it - cell_keys_.begin()) : -1;
}

}  // namespace furn
