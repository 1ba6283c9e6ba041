#include "core/geometry/voxel_grid.h"

#include <algorithm>
#include <boost/sort/spreadsort/integer_sort.hpp>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/geometry/voxel_key.h"

namespace furn {
namespace {

// A point and its cell: the pair PCL sorts (the cell alone orders it).
struct CellOfPoint {
  unsigned int cell;
  unsigned int point;
  bool operator<(const CellOfPoint& other) const { return cell < other.cell; }
};

}  // namespace

std::vector<Eigen::Vector3f> VoxelCentroids(const std::vector<Eigen::Vector3f>& points,
                                            float leaf_m) {
  // The finite points are those PCL would see, in order.
  size_t finite = 0;
  Eigen::Array3f low = Eigen::Array3f::Constant(std::numeric_limits<float>::max());
  Eigen::Array3f high = Eigen::Array3f::Constant(-std::numeric_limits<float>::max());
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite()) continue;
    ++finite;
    low = low.min(p.array());
    high = high.max(p.array());
  }
  std::vector<Eigen::Vector3f> centroids;
  if (finite == 0) return centroids;
  const float inverse = 1.0f / leaf_m;
  double cells = 1;  // PCL's 64-bit count, exact in a double below 2^53
  for (int a = 0; a < 3; ++a) cells *= static_cast<double>((high[a] - low[a]) * inverse) + 1;
  if (!(cells <= std::numeric_limits<int32_t>::max())) {
    for (const Eigen::Vector3f& p : points) {
      if (p.allFinite()) centroids.push_back(p);
    }
    return centroids;
  }
  int64_t corner[3], stride[3];
  for (int a = 0; a < 3; ++a) corner[a] = static_cast<int64_t>(std::floor(low[a] * inverse));
  stride[0] = 1;
  stride[1] = static_cast<int64_t>(std::floor(high[0] * inverse)) - corner[0] + 1;
  stride[2] = stride[1] * (static_cast<int64_t>(std::floor(high[1] * inverse)) - corner[1] + 1);
  const float reach = std::max(low.abs().maxCoeff(), high.abs().maxCoeff()) * inverse;
  // Below 2^23 cells from the origin a float's integer part is exact, and so
  // is PCL's float subtraction of the grid's corner: integers do the same.
  const bool exact_integers = reach < 8388608.0f;
  std::vector<CellOfPoint> keyed;
  keyed.reserve(finite);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite()) continue;
    int64_t cell = 0;
    for (int a = 0; a < 3; ++a) {
      const float t = p[a] * inverse;
      const int64_t offset = exact_integers
                                 ? FloorToInt(t) - corner[a]
                                 : static_cast<int>(std::floor(t) - static_cast<float>(corner[a]));
      cell += offset * stride[a];
    }
    keyed.push_back({static_cast<unsigned int>(cell), static_cast<unsigned int>(i)});
  }
  boost::sort::spreadsort::integer_sort(
      keyed.begin(), keyed.end(), [](const CellOfPoint& x, unsigned offset) {
        return x.cell >> offset;
      });
  for (size_t first = 0; first < keyed.size();) {
    size_t last = first + 1;
    while (last < keyed.size() && keyed[last].cell == keyed[first].cell) ++last;
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    for (size_t k = first; k < last; ++k) sum += points[keyed[k].point];
    centroids.push_back(sum / static_cast<float>(last - first));
    first = last;
  }
  return centroids;
}

}  // namespace furn
