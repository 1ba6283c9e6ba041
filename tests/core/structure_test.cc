// Structure (walls and their fragments) among a scene's segments.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/detector/detector.h"
#include "core/util/random.h"
#include "tests/test_util.h"

namespace furn {
namespace {

ViewSegments WallScene(float wall_top) {
  ViewSegments view;
  Rng rng(5);
  auto add = [&](const Eigen::Vector3f& p, std::vector<int>* segment) {
    segment->push_back(static_cast<int>(view.cloud.points.size()));
    view.cloud.points.push_back(p);
    view.cloud.normals.emplace_back(0, -1, 0);
    view.cloud.curvature.push_back(0);
  };
  std::vector<int> wall;
  std::vector<std::vector<int>> fragments(8);
  for (float x = -1; x <= 1; x += 0.04f) {
    for (float z = 0.1f; z <= wall_top; z += 0.04f) {
      const Eigen::Vector3f p(x, 2 + static_cast<float>(rng.Uniform(-0.01, 0.01)), z);
      const int cell = static_cast<int>(std::lround(x / 0.04f + z / 0.04f));
      if (z < 1.0f && cell % 3 == 0) {  // below 1 m every third point is in a fragment
        add(p, &fragments[static_cast<int>((x + 1) / 0.25f) % 8]);
      } else {
        add(p, &wall);
      }
    }
  }
  std::vector<int> box, far_piece;
  for (float x = -0.5f; x <= 0.5f; x += 0.04f) {
    for (float z = 0; z <= 0.8f; z += 0.04f) add(Eigen::Vector3f(x, 1.4f, z), &box);
  }
  for (float x = 2.5f; x <= 2.8f; x += 0.04f) {
    for (float z = 0.2f; z <= 0.6f; z += 0.04f) add(Eigen::Vector3f(x, 2, z), &far_piece);
  }
  view.segments = {wall, box, far_piece};
  for (const auto& fragment : fragments) view.segments.push_back(fragment);
  return view;
}

TEST(FindStructure, WallsAndTheirFragmentsButNotFurnitureBeforeThem) {
  const ViewSegments view = WallScene(2.2f);
  std::vector<char> segment_flags;
  const std::vector<char> structure = FindStructure(view, 2.5, 1.4f, &segment_flags);
  ASSERT_EQ(structure.size(), view.cloud.size());
  ASSERT_EQ(segment_flags.size(), view.segments.size());
  EXPECT_TRUE(segment_flags[0]);   // the wall: 2.1 m across, but reaching 2.2 m
  EXPECT_FALSE(segment_flags[1]);  // the box
  EXPECT_FALSE(segment_flags[2]);  // on the wall's plane but beyond its span
  for (size_t s = 3; s < view.segments.size(); ++s) EXPECT_TRUE(segment_flags[s]) << s;
  for (int i : view.segments[1]) ASSERT_FALSE(structure[i]);
  for (int i : view.segments[2]) ASSERT_FALSE(structure[i]);
  for (size_t s = 3; s < view.segments.size(); ++s) {
    for (int i : view.segments[s]) ASSERT_TRUE(structure[i]);
  }
}

TEST(FindStructure, ALowNarrowSegmentIsNotStructure) {
  const ViewSegments view = WallScene(1.2f);  // a 2 m x 1.1 m board, lower than 1.4 m
  std::vector<char> segment_flags;
  const std::vector<char> structure = FindStructure(view, 2.5, 1.4f, &segment_flags);
  for (char flag : structure) ASSERT_FALSE(flag);
  // Wider than max_extent makes it structure whatever its height.
  FindStructure(view, 1.5, 1.4f, &segment_flags);
  EXPECT_TRUE(segment_flags[0]);
  EXPECT_TRUE(segment_flags[3]);
  EXPECT_FALSE(segment_flags[1]);
}

}  // namespace
}  // namespace furn
