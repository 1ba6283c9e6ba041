// Over-segmentation by region growing (Mozos et al.; SPEC.md §7.3): seeds in
// order of lowest curvature; a point joins segment S_i when it lies within
// delta of a point of S_i and its normal is within alpha of the seed's normal.
// Segments smaller than the minimum size are dropped.
//
//   RegionGrowingOptions options;                      // 5 cm, 40 degrees
//   std::vector<std::vector<int>> segments = GrowRegions(cloud, options);
#pragma once

#include <vector>

#include "core/geometry/point_cloud.h"

namespace furn {

struct RegionGrowingOptions {
  double delta_m = 0.05;      // neighbour distance (m, 0.005..0.5)
  double alpha_deg = 40.0;    // largest angle to the seed's normal (degrees, 1..90)
  int min_segment_size = 30;  // points (>= 1)

  // Throws InputError naming the field and the rule.
  void Check() const;
};

// Indices into `cloud` per segment, largest segment first (ties by smallest
// first index), each sorted ascending.
std::vector<std::vector<int>> GrowRegions(const PointCloud& cloud,
                                          const RegionGrowingOptions& options);

}  // namespace furn
