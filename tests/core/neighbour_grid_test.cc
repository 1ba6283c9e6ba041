// The neighbour grid against brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/geometry/neighbour_grid.h"
#include "core/util/random.h"
#include "tests/test_util.h"

namespace furn {
namespace {

TEST(NeighbourGrid, MatchesBruteForce) {
  Rng rng(5);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 2000; ++i) {
    points.emplace_back(rng.Uniform(-0.5, 0.5), rng.Uniform(-0.5, 0.5), rng.Uniform(-0.1, 0.1));
  }
  const NeighbourGrid grid(points, 0.05f);
  for (int i = 0; i < 2000; i += 97) {
    std::vector<int> fast, slow;
    grid.ForEachNeighbourOf(i, 0.05f, [&](int j, float) { fast.push_back(j); });
    std::vector<int> by_point;
    grid.ForEachWithin(points[i], 0.05f, [&](int j, float) { by_point.push_back(j); });
    for (int j = 0; j < 2000; ++j) {
      if ((points[j] - points[i]).norm() <= 0.05f) slow.push_back(j);
    }
    std::sort(fast.begin(), fast.end());
    std::sort(by_point.begin(), by_point.end());
    EXPECT_EQ(fast, slow);
    EXPECT_EQ(by_point, slow);
  }
}

// A wall 2 m wide at y = 2 (noisy, split into one large segment and many
// small ones, as Kinect noise splits a wall seen head-on), a box's front
// 60 cm before it, and a small piece of another wall beyond its span.

}  // namespace
}  // namespace furn
