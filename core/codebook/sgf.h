// The 24 Simple Geometric Features of a segment (Mozos et al. 2011, Usenko
// et al. Sec. III-B; SPEC.md §7.4). With e1 >= e2 >= e3 the eigenvalues of the
// segment's covariance and u1, u2, u3 their eigenvectors:
//   [0]      proportion of boundary points (PCL BoundaryEstimation, angle criterion)
//   [1]      mean curvature of the segment's points
//   [2]      occupied volume: occupied 1 cm voxels x voxel volume (m^3)
//   [3..8]   eigenvalue proportions e2/e1, e3/e2, e3/e1, e1/sum, e2/sum, e3/sum
//            (the paper's e1/e2, e2/e3, e1/e3 taken inverted, so they stay in
//            [0, 1]: e3 is 0 on a plane)
//   [9..11]  variances v1, v2, v3 of the points projected on u1, u2, u3 (m^2)
//   [12]     orientation: |cos| of the angle between u3 and z
//   [13..15] extents l_i+ + l_i- along u_i, from the centroid both ways (m)
//   [16..18] min(l_i+, l_i-) / max(l_i+, l_i-)
//   [19]     (l1+ + l1-) / (l2+ + l2-)
//   [20..22] v_i / (l_i+ + l_i-)
//   [23]     occupied volume / oriented bounding box volume (box sides at least
//            one voxel)
// Every feature is unchanged when an eigenvector's sign flips. Normalisation
// to [0, 1] happens later, with the training set's range.
//
//   SgfVector f = ComputeSgf(cloud, segment_indices, SgfOptions{});
#pragma once

#include <array>
#include <vector>

#include "core/geometry/point_cloud.h"

namespace furn {

inline constexpr int kSgfCount = 24;
using SgfVector = std::array<double, kSgfCount>;

struct SgfOptions {
  double voxel_size_m = 0.01;       // occupancy voxel (m, 0.002..0.1)
  double boundary_radius_m = 0.03;  // neighbourhood of the boundary test (m, 0.005..0.2)
  double boundary_angle_deg = 90;   // gap that makes a boundary point (degrees, 10..180)

  // Throws InputError naming the field and the rule.
  void Check() const;
};

// Throws InputError for fewer than 3 points in the segment.
SgfVector ComputeSgf(const PointCloud& cloud,
                     const std::vector<int>& segment,
                     const SgfOptions& options);

}  // namespace furn
