// The floor finder on analytic scans: the floor and camera height, and why none is found.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/geometry/floor.h"
#include "core/util/error.h"
#include "core/util/random.h"
#include "tests/test_util.h"

namespace furn {
namespace {

std::vector<Eigen::Vector3f> FloorScan(bool with_floor) {
  const double pitch = 25 * M_PI / 180;
  // World: z up, camera at (0, 0, 1.3) looking along +y, pitched down.
  const Eigen::Vector3d forward(0, std::cos(pitch), -std::sin(pitch));
  const Eigen::Vector3d right(1, 0, 0);
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d camera_from_world;
  camera_from_world.row(0) = right.transpose();
  camera_from_world.row(1) = down.transpose();
  camera_from_world.row(2) = forward.transpose();
  const Eigen::Vector3d eye(0, 0, 1.3);
  std::vector<Eigen::Vector3f> points;
  for (double x = -1.5; x <= 1.5; x += 0.03) {
    for (double y = 1.0; y <= 4.0; y += 0.03) {
      if (with_floor)
        points.push_back((camera_from_world * (Eigen::Vector3d(x, y, 0) - eye)).cast<float>());
    }
    for (double z = 0.0; z <= 2.4; z += 0.03)  // the far wall
      points.push_back((camera_from_world * (Eigen::Vector3d(x, 4.0, z) - eye)).cast<float>());
  }
  for (double x = -0.2; x <= 0.2; x += 0.02) {  // a box's top at 0.5 m
    for (double y = 2.0; y <= 2.4; y += 0.02)
      points.push_back((camera_from_world * (Eigen::Vector3d(x, y, 0.5) - eye)).cast<float>());
  }
  return points;
}

TEST(FindFloor, FindsTheFloorAndTheCameraHeight) {
  const Eigen::Isometry3d world_from_camera = FindFloor(FloorScan(true), FloorOptions{});
  EXPECT_NEAR(world_from_camera.translation().z(), 1.3, 0.01);
  // The camera's optical axis points 25 degrees below the horizon.
  const Eigen::Vector3d axis = world_from_camera.linear() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(std::asin(-axis.z()) * 180 / M_PI, 25, 0.5);
  // A floor point lands on z = 0.
  const Eigen::Vector3f any_floor_point = FloorScan(true)[0];
  EXPECT_NEAR((world_from_camera * any_floor_point.cast<double>()).z(), 0, 0.01);
}

TEST(FindFloor, NoFloorAndTooFewPointsAreErrors) {
  EXPECT_NE(
      testing::ErrorOf([] { FindFloor(FloorScan(false), FloorOptions{}); }).find("no floor found"),
      std::string::npos);
  EXPECT_NE(testing::ErrorOf([] {
              FindFloor(std::vector<Eigen::Vector3f>(10, Eigen::Vector3f(0, 1, 2)), FloorOptions{});
            }).find("at least 100"),
            std::string::npos);
}

// The detector's floor stage returns its outcome (issue 71: no throw across
// a stage that returns one): the same floor, or why there is none.
TEST(EstimateFloor, ReturnsTheFloorOrWhyNotWithoutThrowing) {
  const FloorEstimate found = EstimateFloor(FloorScan(true), FloorOptions{}, 6);
  ASSERT_TRUE(found.found);
  EXPECT_TRUE(found.world_from_camera.isApprox(FindFloor(FloorScan(true), FloorOptions{})));
  EXPECT_TRUE(found.message.empty());
  FloorEstimate none;
  EXPECT_NO_THROW(none = EstimateFloor(FloorScan(false), FloorOptions{}, 6));
  EXPECT_FALSE(none.found);
  EXPECT_NE(none.message.find("no floor found"), std::string::npos);
  const FloorEstimate out_of_range = EstimateFloor(FloorScan(true), FloorOptions{}, 0.1);
  EXPECT_FALSE(out_of_range.found);
  EXPECT_NE(out_of_range.message.find("at least 100 are needed"), std::string::npos);
}

// floor.sample_points: RANSAC draws from about that many points (every
// k-th); a smaller sample finds the same floor here, and a size outside
// 1000..1000000 is refused by name.
TEST(FindFloor, SampleSizeIsAnOptionWithinItsRange) {
  const std::vector<Eigen::Vector3f> scan = FloorScan(true);
  ASSERT_GT(scan.size(), 15000u);
  FloorOptions small;
  small.sample_points = 2000;
  const Eigen::Isometry3d full = FindFloor(scan, FloorOptions{});
  const Eigen::Isometry3d sampled = FindFloor(scan, small);
  EXPECT_NEAR(sampled.translation().z(), full.translation().z(), 0.01);
  EXPECT_GT((sampled.linear() * Eigen::Vector3d::UnitZ())
                .dot(full.linear() * Eigen::Vector3d::UnitZ()),
            std::cos(0.5 * M_PI / 180));
  for (int bad : {999, 1000001}) {
    FloorOptions options;
    options.sample_points = bad;
    EXPECT_EQ(testing::ErrorOf([&] { FindFloor(scan, options); }),
              "floor sample points " + std::to_string(bad) + " must be in 1000..1000000");
  }
}

}  // namespace
}  // namespace furn
