#include "core/codebook/trainer_options.h"

#include <algorithm>

#include "core/util/error.h"

namespace furn {

void TrainerOptions::Check() const {
  preprocess.Check();
  region_growing.Check();
  sgf.Check();
  vocabulary.Check();
  part_subsets.Check();
  Require(shape_voxel_m >= 0.005 && shape_voxel_m <= 0.1,
          "shape_voxel_m " + std::to_string(shape_voxel_m) + " must be in 0.005..0.1 m");
}

FeatureNormalizer FeatureNormalizer::Fit(const std::vector<SgfVector>& features) {
  Require(!features.empty(), "feature normalisation needs at least one feature");
  FeatureNormalizer normalizer;
  normalizer.low = normalizer.high = features[0];
  for (const SgfVector& f : features) {
    for (int k = 0; k < kSgfCount; ++k) {
      normalizer.low[k] = std::min(normalizer.low[k], f[k]);
      normalizer.high[k] = std::max(normalizer.high[k], f[k]);
    }
  }
  return normalizer;
}

Eigen::VectorXd FeatureNormalizer::Apply(const SgfVector& feature) const {
  Eigen::VectorXd normalised(kSgfCount);
  for (int k = 0; k < kSgfCount; ++k) {
    const double range = high[k] - low[k];
    normalised(k) = range > 0 ? std::clamp((feature[k] - low[k]) / range, 0.0, 1.0) : 0.0;
  }
  return normalised;
}

}  // namespace furn
