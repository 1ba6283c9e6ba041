// The occupancy grid and its visibility score on analytic scans.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "core/geometry/occupancy.h"
#include "core/geometry/pose_fit.h"
#include "core/geometry/voxel_key.h"
#include "core/util/random.h"
#include "tests/test_util.h"

namespace furn {
namespace {

TEST(OccupancyGrid, FreeBeforeASurfaceOccupiedOnItUnknownBehind) {
  // A wall at x = 2 m seen from the origin.
  std::vector<Eigen::Vector3f> wall;
  for (float y = -0.5f; y <= 0.5f; y += 0.02f) {
    for (float z = -0.5f; z <= 0.5f; z += 0.02f) wall.emplace_back(2.0f, y, z);
  }
  const OccupancyGrid grid(wall, Eigen::Vector3f::Zero(), 0.05);
  EXPECT_EQ(grid.At(Eigen::Vector3f(1.0f, 0, 0)), Occupancy::kFree);
  EXPECT_EQ(grid.At(Eigen::Vector3f(2.0f, 0.1f, 0.1f)), Occupancy::kOccupied);
  EXPECT_EQ(grid.At(Eigen::Vector3f(2.3f, 0, 0)), Occupancy::kUnknown);
  EXPECT_EQ(grid.At(Eigen::Vector3f(50, 0, 0)), Occupancy::kUnknown);  // outside the grid
  // Model points in front of the wall are in free space: a low score; on it
  // and behind it: a high one (vs = (5 occ + occl) / (5 occ + occl + free)).
  std::vector<Eigen::Vector3f> floating, on_wall;
  for (float y = -0.2f; y <= 0.2f; y += 0.05f) {
    floating.emplace_back(1.0f, y, 0);
    on_wall.emplace_back(2.0f, y, 0);
    on_wall.emplace_back(2.3f, y, 0);
  }
  const VisibilityCounts in_front = CountVisibility(grid, floating, -10);
  EXPECT_EQ(in_front.free, static_cast<int>(floating.size()));
  EXPECT_DOUBLE_EQ(in_front.Score(5), 0.0);
  const VisibilityCounts behind = CountVisibility(grid, on_wall, -10);
  EXPECT_EQ(behind.free, 0);
  EXPECT_EQ(behind.occupied, behind.occluded);
  EXPECT_DOUBLE_EQ(behind.Score(5), 1.0);
  EXPECT_DOUBLE_EQ(behind.SeenOccupied(), 1.0);
}

// Camera-frame points of a floor 1.3 m below a camera pitched down 25
// degrees, plus a box standing on it.

// The ray ends: the first point of each VoxelKey cell, in order, as a hash
// set of keys keeps them; the box of bits and both of its fallbacks (a box
// of too many cells, an axis past VoxelKey's 21-bit field, where two cells
// share a key).
std::vector<Eigen::Vector3f> FirstPointPerKey(const std::vector<Eigen::Vector3f>& points,
                                              double voxel_m) {
  std::unordered_set<uint64_t> taken;
  std::vector<Eigen::Vector3f> kept;
  for (const Eigen::Vector3f& p : points) {
    if (taken.insert(VoxelKey(p, voxel_m)).second) kept.push_back(p);
  }
  return kept;
}

TEST(FirstPointPerVoxel, IsTheFirstPointOfEachKeyInOrder) {
  Rng random(3);
  std::vector<Eigen::Vector3f> room, far_apart, long_axis;
  for (int i = 0; i < 30000; ++i) {
    const Eigen::Vector3f p(static_cast<float>(random.Uniform(-4, 3)),
                            static_cast<float>(random.Uniform(-1, 6)),
                            static_cast<float>(random.Uniform(0, 2.6)));
    room.push_back(p);
    far_apart.push_back(i % 2 ? p : p + Eigen::Vector3f(9000, 9000, 900));  // 2^32 cells
    const Eigen::Vector3f on_line(p.x(), 0.01f, 0.01f);  // a box of few cells, one long axis
    long_axis.push_back(i % 2 ? on_line : on_line + Eigen::Vector3f(0.05f * (1 << 21), 0, 0));
  }
  for (const auto* points : {&room, &far_apart, &long_axis}) {
    const std::vector<Eigen::Vector3f> kept = FirstPointPerVoxel(*points, 0.05);
    EXPECT_LT(kept.size(), points->size());
    EXPECT_EQ(kept, FirstPointPerKey(*points, 0.05));
  }
  EXPECT_TRUE(FirstPointPerVoxel({}, 0.05).empty());
}

}  // namespace
}  // namespace furn
