#include "core/codebook/region_growing.h"

#include <algorithm>
#include <cmath>

#include "core/geometry/neighbour_grid.h"
#include "core/util/error.h"

namespace furn {

void RegionGrowingOptions::Check() const {
  Require(delta_m >= 0.005 && delta_m <= 0.5,
          "delta_m " + std::to_string(delta_m) + " must be in [0.005, 0.5]");
  Require(alpha_deg >= 1 && alpha_deg <= 90,
          "alpha_deg " + std::to_string(alpha_deg) + " must be in [1, 90]");
  Require(min_segment_size >= 1,
          "min_segment_size " + std::to_string(min_segment_size) + " must be >= 1");
}

std::vector<std::vector<int>> GrowRegions(const PointCloud& cloud,
                                          const RegionGrowingOptions& options) {
  options.Check();
  Require(cloud.normals.size() == cloud.size() && cloud.curvature.size() == cloud.size(),
          "region growing needs a normal and a curvature per point");
  std::vector<std::vector<int>> segments;
  if (cloud.size() == 0) return segments;
  const float delta = static_cast<float>(options.delta_m);
  const NeighbourGrid grid(cloud.points, delta);

  // Seeds by increasing curvature; ties by index, so the result is
  // deterministic (pairs sorted once: the order a stable sort by curvature
  // gives).
  std::vector<std::pair<float, int>> by_curvature(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i)
    by_curvature[i] = {cloud.curvature[i], static_cast<int>(i)};
  std::sort(by_curvature.begin(), by_curvature.end());
  std::vector<int> order(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) order[i] = by_curvature[i].second;
  const float min_cosine = static_cast<float>(std::cos(options.alpha_deg * M_PI / 180));
  std::vector<int> label(cloud.size(), -1);
  int next_label = 0;
  std::vector<int> unlabelled(grid.NumCells());  // points per cell without a label yet
  for (int c = 0; c < grid.NumCells(); ++c) unlabelled[c] = grid.CellSize(c);
  for (int seed : order) {
    if (label[seed] != -1) continue;
    const Eigen::Vector3f& seed_normal = cloud.normals[seed];
    std::vector<int> segment = {seed};
    label[seed] = next_label;
    --unlabelled[grid.CellOfPoint(seed)];
    for (size_t head = 0; head < segment.size(); ++head) {
      grid.ForEachNeighbourOf(
          segment[head],
          delta,
          [&](int cell) { return unlabelled[cell] == 0; },  // nothing left to take there
          [&](int q) { return label[q] != -1; },            // taken
          [&](int q, float) {
            if (cloud.normals[q].dot(seed_normal) < min_cosine) return;
            label[q] = next_label;
            --unlabelled[grid.CellOfPoint(q)];
            segment.push_back(q);
          });
    }
    ++next_label;
    if (static_cast<int>(segment.size()) < options.min_segment_size) continue;
    std::sort(segment.begin(), segment.end());
    segments.push_back(std::move(segment));
  }
  std::stable_sort(segments.begin(), segments.end(), [](const auto& a, const auto& b) {
    return a.size() != b.size() ? a.size() > b.size() : a.front() < b.front();
  });
  return segments;
}

}  // namespace furn
