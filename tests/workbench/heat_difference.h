// Comparing two vote networks in tests (data-parallel training against one
// process): the largest difference of their heat channels on the same images.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/learned/vote_net.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn::testing {

inline double LargestHeatDifference(const VoteNet& a,
                                    const VoteNet& b,
                                    const std::vector<BevSample>& at) {
  double largest = 0;
  for (const BevSample& sample : at) {
    const BevOutput x = a.Predict(sample.image), y = b.Predict(sample.image);
    for (int k = 0; k < kBevClasses; ++k) {
      for (int r = 0; r < x.spec.rows; ++r) {
        for (int c = 0; c < x.spec.cols; ++c)
          largest = std::max(largest, std::abs(double(x.At(k, r, c)) - y.At(k, r, c)));
      }
    }
  }
  return largest;
}

}  // namespace furn::testing
