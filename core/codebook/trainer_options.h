// What the codebook's training and detection's segmentation share: the
// preprocessing, region growing, SGF, vocabulary and part-subset options
// (stored in the model file), and the SGFs' normalisation.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/codebook/part_subsets.h"
#include "core/codebook/preprocess.h"
#include "core/codebook/region_growing.h"
#include "core/codebook/sgf.h"
#include "core/codebook/vocabulary.h"

namespace furn {

struct TrainerOptions {
  PreprocessOptions preprocess;
  RegionGrowingOptions region_growing;
  SgfOptions sgf;
  VocabularyOptions vocabulary;
  PartSubsetOptions part_subsets;  // the part-subset library for CAD model ranking
  double shape_voxel_m = 0.02;     // grid of the stored model shapes (m, 0.005..0.1)

  void Check() const;
};

// Min/max of every feature over the training set; Apply maps to [0, 1] and
// clamps (a scene's own features never widen the range: SPEC §14).
struct FeatureNormalizer {
  SgfVector low{};
  SgfVector high{};

  static FeatureNormalizer Fit(const std::vector<SgfVector>& features);
  Eigen::VectorXd Apply(const SgfVector& feature) const;
};

}  // namespace furn
