#include "core/geometry/neighbour_grid.h"

#include <algorithm>
#include <numeric>

#include "core/util/error.h"

namespace furn {

NeighbourGrid::NeighbourGrid(const std::vector<Eigen::Vector3f>& points, float cell)
    : points_(points), inverse_cell_(1.0f / cell) {
  Require(cell > 0, "neighbour grid cell must be > 0");
  std::vector<uint64_t> keys(points.size());
  for (size_t i = 0; i < points.size(); ++i) keys[i] = Key(CellOf(points[i]));
  order_.resize(points.size());
  std::iota(order_.begin(), order_.end(), 0);
  std::stable_sort(order_.begin(), order_.end(), [&](int a, int b) { return keys[a] < keys[b]; });
  cells_.reserve(points.size() / 4 + 1);
  cell_of_point_.resize(points.size());
  for (size_t k = 0; k < order_.size();) {
    size_t end = k + 1;
    while (end < order_.size() && keys[order_[end]] == keys[order_[k]]) ++end;
    const int cell = static_cast<int>(ranges_.size());
    ranges_.emplace_back(static_cast<int>(k), static_cast<int>(end));
    cells_.emplace(keys[order_[k]], cell);
    for (size_t m = k; m < end; ++m) cell_of_point_[order_[m]] = cell;
    k = end;
  }
  neighbour_begin_.reserve(ranges_.size() + 1);
  for (const auto& [begin, end] : ranges_) {
    neighbour_begin_.push_back(static_cast<int>(neighbour_cells_.size()));
    const Eigen::Vector3i centre = CellOf(points[order_[begin]]);
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = cells_.find(Key(centre + Eigen::Vector3i(dx, dy, dz)));
          if (it != cells_.end()) neighbour_cells_.push_back(it->second);
        }
      }
    }
  }
  neighbour_begin_.push_back(static_cast<int>(neighbour_cells_.size()));
}

}  // namespace furn
