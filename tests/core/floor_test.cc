// The floor finder on analytic scans: the floor and camera height, and why none is found.
#include <gtest/gtest.h>

#include <pcl/features/normal_3d.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/sac_model_plane.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <cmath>

#include "core/geometry/floor.h"
#include "core/util/error.h"
#include "core/util/random.h"
#include "tests/core/real_captures.h"
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
  EXPECT_GT(
      (sampled.linear() * Eigen::Vector3d::UnitZ()).dot(full.linear() * Eigen::Vector3d::UnitZ()),
      std::cos(0.5 * M_PI / 180));
  for (int bad : {999, 1000001}) {
    FloorOptions options;
    options.sample_points = bad;
    EXPECT_EQ(testing::ErrorOf([&] { FindFloor(scan, options); }),
              "floor sample points " + std::to_string(bad) + " must be in 1000..1000000");
  }
}

// The floor RANSAC's inlier count is PCL's to the point (so the floor found
// is the one PCL's SACSegmentation found): on points placed within a few
// float steps of the threshold on either side, for planes of every
// direction, CountNearPlane and PCL's plane model agree; summing the
// products in another order does not (the test can tell).
TEST(CountNearPlane, CountsAsPclsPlaneModelDoesAtTheThreshold) {
  Rng rng(3);
  constexpr double kThreshold = 0.02;
  size_t planes_where_order_matters = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Eigen::Vector3f normal(static_cast<float>(rng.Uniform(-1, 1)),
                           static_cast<float>(rng.Uniform(-1, 1)),
                           static_cast<float>(rng.Uniform(-1, 1)));
    normal.normalize();
    const float offset = static_cast<float>(rng.Uniform(-3, 3));
    auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    std::vector<float> x, y, z;
    for (int i = 0; i < 1003; ++i) {  // not a multiple of four: the tail too
      Eigen::Vector3f on_plane(static_cast<float>(rng.Uniform(-4, 4)),
                               static_cast<float>(rng.Uniform(-4, 4)),
                               static_cast<float>(rng.Uniform(-4, 4)));
      on_plane -= (normal.dot(on_plane) + offset) * normal;
      const double side = i % 2 == 0 ? 1 : -1;
      const double step = rng.Uniform(-4e-7, 4e-7);
      const Eigen::Vector3f p = on_plane + static_cast<float>(side * (kThreshold + step)) * normal;
      cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
      x.push_back(p.x());
      y.push_back(p.y());
      z.push_back(p.z());
    }
    pcl::SampleConsensusModelPlane<pcl::PointXYZ> model(cloud);
    Eigen::VectorXf coefficients(4);
    coefficients << normal.x(), normal.y(), normal.z(), offset;
    const size_t pcl_count = model.countWithinDistance(coefficients, kThreshold);
    ASSERT_GT(pcl_count, 0u);
    ASSERT_LT(pcl_count, x.size());
    ASSERT_EQ(CountNearPlane(x, y, z, coefficients.head<4>(), kThreshold), pcl_count)
        << "plane " << trial;
    // Both code paths, whichever the CPU would pick (1003 points: both
    // vector loops and their tails).
    ASSERT_EQ(CountNearPlane(x, y, z, coefficients.head<4>(), kThreshold, SimdPath::kSse2),
              pcl_count)
        << "plane " << trial << ", SSE2";
    if (__builtin_cpu_supports("avx2")) {
      ASSERT_EQ(CountNearPlane(x, y, z, coefficients.head<4>(), kThreshold, SimdPath::kAvx2),
                pcl_count)
          << "plane " << trial << ", AVX2";
    }
    size_t in_order = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      const float d = normal.x() * x[i] + normal.y() * y[i] + normal.z() * z[i] + offset;
      in_order += std::abs(d) < kThreshold;
    }
    planes_where_order_matters += in_order != pcl_count;
  }
  EXPECT_GT(planes_where_order_matters, 0u);
}

// The floor's facing-up pass (a room seen level) marks the points PCL's
// NormalEstimation (12 nearest, k-d tree) marked, on every real scan of the
// repository subsampled as the floor search does, and on the analytic scan.
std::vector<bool> PclFacingUp(const std::vector<Eigen::Vector3f>& points, double max_tilt_deg) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (const Eigen::Vector3f& p : points) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
  estimation.setInputCloud(cloud);
  estimation.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimation.setKSearch(12);
  pcl::PointCloud<pcl::Normal> normals;
  estimation.compute(normals);
  const double cos_tilt = std::cos(max_tilt_deg * M_PI / 180);
  std::vector<bool> facing_up(points.size(), false);
  for (size_t i = 0; i < points.size(); ++i)
    facing_up[i] = std::isfinite(normals[i].normal_y) && std::abs(normals[i].normal_y) >= cos_tilt;
  return facing_up;
}

TEST(FacingUpPoints, MarksThePointsPclsNormalEstimationMarks) {
  std::vector<std::vector<Eigen::Vector3f>> scans = {FloorScan(true)};
  for (int k = 1; k <= kRealCaptures; ++k) {
    std::vector<Eigen::Vector3f> points, finite;
    ASSERT_TRUE(LoadRealCapture(k, &points)) << RealCapturePath(k);
    for (const Eigen::Vector3f& p : points) {
      if (p.allFinite()) finite.push_back(p);
    }
    std::vector<Eigen::Vector3f> sample;  // every k-th, about 20,000: the floor's sample
    const size_t stride = std::max<size_t>(1, finite.size() / 20000);
    for (size_t i = 0; i < finite.size(); i += stride) sample.push_back(finite[i]);
    scans.push_back(sample);
  }
  for (size_t s = 0; s < scans.size(); ++s) {
    for (double tilt : {10.0, 30.0}) {  // the analytic camera is pitched 25 degrees
      const std::vector<bool> ours = FacingUpPoints(scans[s], tilt);
      const std::vector<bool> pcl = PclFacingUp(scans[s], tilt);
      const size_t up = static_cast<size_t>(std::count(ours.begin(), ours.end(), true));
      if (tilt == 30.0) {
        EXPECT_GT(up, 0u) << "scan " << s;
      }
      EXPECT_LT(up, ours.size()) << "scan " << s;
      EXPECT_TRUE(ours == pcl) << "scan " << s << ", tilt " << tilt;
    }
  }
  EXPECT_EQ(testing::ErrorOf([] { FacingUpPoints({Eigen::Vector3f(0, 0, std::nanf(""))}, 10); }),
            "FacingUpPoints: every point must be finite");
}

}  // namespace
}  // namespace furn
