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

// Visits go cell by cell (z outermost, then y, then x, each -1, 0, +1
// around the point's cell), points by index within a cell: the order the
// normal fit sums in, so its results depend on it. Checked against that
// order built by brute force, for points on both sides of every axis.
TEST(NeighbourGrid, VisitsCellsInZYXOrderAndPointsByIndex) {
  Rng rng(11);
  constexpr float kCell = 0.04f;
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 3000; ++i) {
    points.emplace_back(rng.Uniform(-0.3, 0.3), rng.Uniform(-0.3, 0.3), rng.Uniform(-0.3, 0.3));
  }
  const NeighbourGrid grid(points, kCell);
  auto cell_of = [&](const Eigen::Vector3f& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() * (1.0f / kCell))),
                           static_cast<int>(std::floor(p.y() * (1.0f / kCell))),
                           static_cast<int>(std::floor(p.z() * (1.0f / kCell))));
  };
  for (int i = 0; i < 3000; i += 37) {
    std::vector<int> visited, expected;
    grid.ForEachNeighbourOf(i, kCell, [&](int j, float) { visited.push_back(j); });
    const Eigen::Vector3i centre = cell_of(points[i]);
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          for (int j = 0; j < 3000; ++j) {
            if (cell_of(points[j]) == centre + Eigen::Vector3i(dx, dy, dz) &&
                (points[j] - points[i]).squaredNorm() <= kCell * kCell) {
              expected.push_back(j);
            }
          }
        }
      }
    }
    ASSERT_EQ(visited, expected) << "point " << i;
  }
}

// A wall 2 m wide at y = 2 (noisy, split into one large segment and many
// small ones, as Kinect noise splits a wall seen head-on), a box's front
// 60 cm before it, and a small piece of another wall beyond its span.

}  // namespace
}  // namespace furn
