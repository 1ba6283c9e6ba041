// Several posed scans as one detection input (core/geometry/scan_fusion.h), and the
// random pose error that measures what fusion loses to odometry.
#include "core/geometry/scan_fusion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/util/random.h"
#include "tests/test_util.h"

namespace furn {
namespace {

Eigen::Isometry3d Pose(double x, double y, double z, double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(x, y, z);
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

DetectionInput Scan(const Eigen::Isometry3d& pose, std::vector<Eigen::Vector3f> points) {
  DetectionInput scan;
  scan.points = std::move(points);
  scan.world_from_camera = pose;
  return scan;
}

TEST(ScanFusion, EveryScansPointsLandInTheReferenceCamerasFrame) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Eigen::Isometry3d a = Pose(0, 0, 1.2, 0.3), b = Pose(2, -1, 1.0, -1.1);
  DetectionInput first = Scan(a, {{0.1f, 0.2f, 2.0f}, {nan, nan, nan}});
  first.width = 2;  // organised: 2 x 1
  first.height = 1;
  const DetectionInput second = Scan(b, {{-0.3f, 0.1f, 1.5f}, {0.0f, 0.0f, 3.0f}});
  const DetectionInput fused = FuseScans({first, second}, 0);
  ASSERT_EQ(fused.points.size(), 3u);  // the NaN is left out
  EXPECT_EQ(fused.width, 0);           // unorganised
  EXPECT_EQ(fused.height, 0);
  ASSERT_TRUE(fused.world_from_camera.has_value());
  EXPECT_TRUE(fused.world_from_camera->isApprox(a));
  // Each point keeps its place in the world.
  const std::vector<Eigen::Vector3f> world = {(a * first.points[0].cast<double>()).cast<float>(),
                                              (b * second.points[0].cast<double>()).cast<float>(),
                                              (b * second.points[1].cast<double>()).cast<float>()};
  for (size_t k = 0; k < 3; ++k) {
    const Eigen::Vector3d back = a * fused.points[k].cast<double>();
    EXPECT_LT((back.cast<float>() - world[k]).norm(), 1e-5f) << k;
  }
  // Seen from the second camera instead: its own points stay as they were.
  const DetectionInput from_second = FuseScans({first, second}, 1);
  EXPECT_TRUE(from_second.world_from_camera->isApprox(b));
  EXPECT_LT((from_second.points[1] - second.points[0]).norm(), 1e-5f);
  // One scan is returned whole, organised as it was and without a pose check.
  DetectionInput alone = first;
  alone.world_from_camera.reset();
  const DetectionInput same = FuseScans({alone}, 0);
  EXPECT_EQ(same.points.size(), 2u);
  EXPECT_EQ(same.width, 2);
}

TEST(ScanFusion, NoScansABadReferenceAndAScanWithoutPoseAreRefused) {
  EXPECT_NE(testing::ErrorOf([] { FuseScans({}, 0); }).find("at least one scan"),
            std::string::npos);
  const DetectionInput posed = Scan(Pose(0, 0, 1, 0), {{0, 0, 1}});
  EXPECT_NE(testing::ErrorOf([&] {
              FuseScans({posed, posed}, 2);
            }).find("reference scan 2 of 2 scans"),
            std::string::npos);
  DetectionInput bare = posed;
  bare.world_from_camera.reset();
  EXPECT_NE(testing::ErrorOf([&] {
              FuseScans({posed, bare}, 0);
            }).find("scan 2 of 2 has no pose"),
            std::string::npos);
}

TEST(ScanFusion, PoseErrorHasTheAskedSpreadAndIsTheSameForASeed) {
  const Eigen::Isometry3d pose = Pose(1, 2, 1.1, 0.7);
  FastRng none(3);
  EXPECT_TRUE(PerturbedPose(pose, 0, 0, none).isApprox(pose));
  FastRng first(11), again(11), other(12);
  const Eigen::Isometry3d a = PerturbedPose(pose, 0.05, 0.02, first);
  EXPECT_TRUE(a.isApprox(PerturbedPose(pose, 0.05, 0.02, again)));
  EXPECT_FALSE(a.isApprox(PerturbedPose(pose, 0.05, 0.02, other)));
  // Over many draws: sigma per axis, a proper rotation of about sigma per axis.
  FastRng rng(5);
  double squared_m = 0, squared_rad = 0;
  constexpr int kDraws = 4000;
  for (int k = 0; k < kDraws; ++k) {
    const Eigen::Isometry3d p = PerturbedPose(pose, 0.05, 0.02, rng);
    EXPECT_NEAR(p.linear().determinant(), 1.0, 1e-9);
    ASSERT_TRUE((p.linear() * p.linear().transpose()).isIdentity(1e-9));
    squared_m += (p.translation() - pose.translation()).squaredNorm();
    squared_rad += std::pow(Eigen::AngleAxisd(p.linear() * pose.linear().transpose()).angle(), 2);
  }
  EXPECT_NEAR(std::sqrt(squared_m / (3 * kDraws)), 0.05, 0.003);
  EXPECT_NEAR(std::sqrt(squared_rad / (3 * kDraws)), 0.02, 0.0015);
  EXPECT_NE(testing::ErrorOf([&] { PerturbedPose(pose, -0.1, 0, rng); }).find("spreads"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] { PerturbedPose(pose, 0, std::nan(""), rng); }).find("spreads"),
            std::string::npos);

  // Planar: the same draws along x and y and about z, height and tilt kept.
  FastRng full_rng(21), planar_rng(21);
  const Eigen::Isometry3d full = PerturbedPose(pose, 0.05, 0.02, full_rng);
  const Eigen::Isometry3d planar = PerturbedPose(pose, 0.05, 0.02, planar_rng, true);
  EXPECT_EQ(planar.translation().head<2>(), full.translation().head<2>());
  EXPECT_EQ(planar.translation().z(), pose.translation().z());
  EXPECT_TRUE(planar.linear().row(2).isApprox(pose.linear().row(2), 1e-12));
  EXPECT_GT(Eigen::AngleAxisd(planar.linear() * pose.linear().transpose()).angle(), 1e-4);
}

// A room corner (floor, two walls) with a box on the floor, sampled every
// 2 cm: the points a registration can lock onto in all six directions.
std::vector<Eigen::Vector3d> CornerWithBox() {
  std::vector<Eigen::Vector3d> world;
  for (double a = 0; a < 4; a += 0.02) {
    for (double b = 0; b < 4; b += 0.02) world.emplace_back(a, b, 0);  // floor
    for (double z = 0; z < 2.5; z += 0.02) {
      world.emplace_back(0, a, z);  // wall x = 0
      world.emplace_back(a, 4, z);  // wall y = 4
    }
  }
  for (double a = 0; a < 0.8; a += 0.02) {
    for (double b = 0; b < 0.8; b += 0.02) {
      world.emplace_back(1.6 + a, 1.8 + b, 0.8);  // the box's top and two sides
      world.emplace_back(1.6, 1.8 + a, b);
      world.emplace_back(1.6 + a, 1.8, b);
    }
  }
  return world;
}

// The points with x in [low, high) as a scan from `pose` (camera frame).
DetectionInput ScanOf(const std::vector<Eigen::Vector3d>& world,
                      const Eigen::Isometry3d& pose,
                      double low,
                      double high) {
  DetectionInput scan;
  const Eigen::Isometry3d camera_from_world = pose.inverse();
  for (const Eigen::Vector3d& p : world)
    if (p.x() >= low && p.x() < high) scan.points.push_back((camera_from_world * p).cast<float>());
  scan.world_from_camera = pose;
  return scan;
}

TEST(ScanRegistration, OdometrysErrorIsTakenOutAndAStrangerIsLeftAlone) {
  const std::vector<Eigen::Vector3d> world = CornerWithBox();
  const Eigen::Isometry3d a = Pose(3.2, 1.0, 1.4, 2.4), b = Pose(2.6, 0.6, 1.3, 1.9);
  const DetectionInput first = ScanOf(world, a, 0, 3);
  DetectionInput second = ScanOf(world, b, 0.8, 4);
  // Odometry's error on the second pose: 3 cm and 2 degrees.
  Eigen::Isometry3d off = b;
  off.translation() += Eigen::Vector3d(0.02, -0.02, 0.01);
  off.linear() = (Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix() *
                 b.linear();
  second.world_from_camera = off;
  const std::vector<RegisteredPose> poses = RegisterScans({first, second}, 0, {});
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_FALSE(poses[0].refined);
  EXPECT_TRUE(poses[0].world_from_camera.isApprox(a));
  ASSERT_TRUE(poses[1].refined);
  EXPECT_LT((poses[1].world_from_camera.translation() - b.translation()).norm(), 0.01);
  EXPECT_LT(Eigen::AngleAxisd(poses[1].world_from_camera.linear() * b.linear().transpose()).angle(),
            0.3 * M_PI / 180);
  EXPECT_LT(poses[1].rms_after_m, poses[1].rms_before_m);
  EXPECT_GT(poses[1].paired, 1000);
  // Registered again from its own result: the same poses (deterministic).
  const std::vector<RegisteredPose> again = RegisterScans({first, second}, 0, {});
  EXPECT_TRUE(again[1].world_from_camera.isApprox(poses[1].world_from_camera, 1e-12));

  // A scan of somewhere else pairs with nothing: its pose stays.
  DetectionInput stranger = second;
  stranger.world_from_camera->translation() += Eigen::Vector3d(20, 0, 0);
  const std::vector<RegisteredPose> alone = RegisterScans({first, stranger}, 0, {});
  EXPECT_FALSE(alone[1].refined);
  EXPECT_TRUE(alone[1].world_from_camera.isApprox(*stranger.world_from_camera));
  EXPECT_EQ(alone[1].paired, 0);

  // Planar registration (a ground robot's odometry: x, y and yaw off) takes
  // the error out too, and leaves height, roll and pitch exactly as given.
  Eigen::Isometry3d drifted = b;
  drifted.translation() += Eigen::Vector3d(0.03, -0.02, 0);
  drifted.linear() =
      Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitZ()).toRotationMatrix() * b.linear();
  second.world_from_camera = drifted;
  ScanRegistrationOptions planar;
  planar.planar = true;
  const std::vector<RegisteredPose> level = RegisterScans({first, second}, 0, planar);
  ASSERT_TRUE(level[1].refined);
  const Eigen::Isometry3d& found = level[1].world_from_camera;
  EXPECT_LT((found.translation() - b.translation()).norm(), 0.01);
  EXPECT_LT(Eigen::AngleAxisd(found.linear() * b.linear().transpose()).angle(), 0.3 * M_PI / 180);
  EXPECT_NEAR(found.translation().z(), drifted.translation().z(), 1e-6);
  EXPECT_TRUE(found.linear().row(2).isApprox(drifted.linear().row(2), 1e-6));
  EXPECT_LT(level[1].rms_after_m, level[1].rms_before_m);
  EXPECT_TRUE(
      RegisterScans({first, second}, 0, planar)[1].world_from_camera.isApprox(found, 1e-12));

  ScanRegistrationOptions bad;
  bad.voxel_m = 0;
  EXPECT_NE(testing::ErrorOf([&] {
              RegisterScans({first, second}, 0, bad);
            }).find("voxel_m"),
            std::string::npos);
  bad = {};
  bad.iterations = 0;
  EXPECT_NE(testing::ErrorOf([&] { bad.Check(); }).find("iterations 0 must be in 1..1000"),
            std::string::npos);
  bad = {};
  bad.min_pairs = 5;
  EXPECT_NE(testing::ErrorOf([&] { bad.Check(); }).find("min_pairs 5 must be >= 10"),
            std::string::npos);
  bad = {};
  bad.min_improvement = 1;
  EXPECT_NE(testing::ErrorOf([&] { bad.Check(); }).find("min_improvement"), std::string::npos);
}

}  // namespace
}  // namespace furn
