// The segments of one view as training and detection see them: the
// preprocessed cloud, the region-growing segments (indices into the cloud),
// their raw (not normalised) SGFs and centroids.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/codebook/sgf.h"
#include "core/geometry/point_cloud.h"

namespace furn {

struct ViewSegments {
  PointCloud cloud;
  std::vector<std::vector<int>> segments;
  std::vector<SgfVector> features;
  std::vector<Eigen::Vector3f> centroids;
};

}  // namespace furn
