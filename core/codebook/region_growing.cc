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
  const float min_cosine = static_cast<float>(std::cos(options.alpha_deg * M_PI / 180));
  // The growth runs in the grid's slots (a cell's points side by side), its
  // labels and normals kept in that order: a neighbourhood's reads are then
  // in sequence, not scattered over the cloud. The same visits in the same
  // order as over point indices, so the same segments.
  const int count = static_cast<int>(cloud.size());
  std::vector<int> slot_of_point(count), cell_of_slot(count);
  std::vector<Eigen::Vector3f> normal_of_slot(count);
  for (int k = 0; k < count; ++k) {
    slot_of_point[grid.PointOfSlot(k)] = k;
    normal_of_slot[k] = cloud.normals[grid.PointOfSlot(k)];
  }
  std::vector<int> unlabelled(grid.NumCells());  // slots per cell without a label yet
  for (int c = 0; c < grid.NumCells(); ++c) {
    const auto [first, end] = grid.SlotsOfCell(c);
    for (int k = first; k < end; ++k) cell_of_slot[k] = c;
    unlabelled[c] = end - first;
  }
  std::vector<int> label(count, -1);  // per slot
  int next_label = 0;
  for (const auto& [curvature, seed] : by_curvature) {
    const int seed_slot = slot_of_point[seed];
    if (label[seed_slot] != -1) continue;
    const Eigen::Vector3f seed_normal = normal_of_slot[seed_slot];
    std::vector<int> segment = {seed_slot};
    label[seed_slot] = next_label;
    --unlabelled[cell_of_slot[seed_slot]];
    for (size_t head = 0; head < segment.size(); ++head) {
      grid.ForEachNeighbourOfSlot(
          segment[head],
          delta,
          [&](int cell) { return unlabelled[cell] == 0; },  // nothing left to take there
          [&](int k) { return label[k] != -1; },            // taken
          [&](int k, float) {
            if (normal_of_slot[k].dot(seed_normal) < min_cosine) return;
            label[k] = next_label;
            --unlabelled[cell_of_slot[k]];
            segment.push_back(k);
          });
    }
    ++next_label;
    if (static_cast<int>(segment.size()) < options.min_segment_size) continue;
    for (int& member : segment) member = grid.PointOfSlot(member);
    std::sort(segment.begin(), segment.end());
    segments.push_back(std::move(segment));
  }
  std::stable_sort(segments.begin(), segments.end(), [](const auto& a, const auto& b) {
    return a.size() != b.size() ? a.size() > b.size() : a.front() < b.front();
  });
  return segments;
}

}  // namespace furn
