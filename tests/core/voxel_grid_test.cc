// The voxel grid against PCL's own VoxelGrid<PointXYZ>: the same centroids,
// in the same order, to the bit (a real organised scan with its NaNs, moved
// into a world frame; points on cell edges; far from the origin; a leaf too
// small for the extent), and a check that summing a cell in another order
// differs, so the comparison can fail.
#include <gtest/gtest.h>

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <map>

#include "core/geometry/voxel_grid.h"
#include "core/geometry/voxel_key.h"
#include "core/util/random.h"
#include "tests/core/real_captures.h"

namespace furn {
namespace {

std::vector<Eigen::Vector3f> PclCentroids(const std::vector<Eigen::Vector3f>& points, float leaf) {
  auto input = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (const Eigen::Vector3f& p : points) {
    if (p.allFinite()) input->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  pcl::PointCloud<pcl::PointXYZ> output;
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setLeafSize(leaf, leaf, leaf);
  grid.setInputCloud(input);
  grid.filter(output);
  std::vector<Eigen::Vector3f> centroids;
  for (const pcl::PointXYZ& p : output) centroids.emplace_back(p.x, p.y, p.z);
  return centroids;
}

bool SameBits(const std::vector<Eigen::Vector3f>& a, const std::vector<Eigen::Vector3f>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
}

std::vector<Eigen::Vector3f> RealScan() {
  std::vector<Eigen::Vector3f> points;
  EXPECT_TRUE(LoadRealCapture(1, &points)) << RealCapturePath(1);
  // Into a world frame: pitched, turned, lifted and moved (negative cells).
  const Eigen::Affine3f world = Eigen::Translation3f(-3.7f, 12.2f, 1.31f) *
                                Eigen::AngleAxisf(0.7f, Eigen::Vector3f::UnitZ()) *
                                Eigen::AngleAxisf(-1.9f, Eigen::Vector3f::UnitX());
  for (Eigen::Vector3f& p : points) p = world * p;
  return points;
}

TEST(VoxelGrid, RealScanIsPclsToTheBit) {
  const std::vector<Eigen::Vector3f> points = RealScan();
  ASSERT_GT(points.size(), 200000u);
  for (float leaf : {0.005f, 0.015f, 0.02f, 0.05f}) {
    const std::vector<Eigen::Vector3f> ours = VoxelCentroids(points, leaf);
    ASSERT_GT(ours.size(), 1000u) << leaf;
    EXPECT_TRUE(SameBits(ours, PclCentroids(points, leaf))) << "leaf " << leaf;
  }
}

TEST(VoxelGrid, AnotherSummingOrderDiffers) {
  // The same cells summed in the points' order: some centroid differs in
  // its last bits, so the comparison above can tell orders apart.
  const std::vector<Eigen::Vector3f> points = RealScan();
  const float leaf = 0.02f;
  const std::vector<Eigen::Vector3f> pcl_centroids = PclCentroids(points, leaf);
  std::map<std::tuple<int, int, int>, std::pair<Eigen::Vector3f, int>> cells;
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite()) continue;
    const float inverse = 1.0f / leaf;  // PCL's cells
    auto& [sum, count] = cells[{static_cast<int>(std::floor(p.z() * inverse)),
                                static_cast<int>(std::floor(p.y() * inverse)),
                                static_cast<int>(std::floor(p.x() * inverse))}];
    if (count == 0) sum.setZero();
    sum += p;
    ++count;
  }
  ASSERT_EQ(cells.size(), pcl_centroids.size());
  size_t differing = 0, index = 0;
  for (const auto& [cell, sum_count] : cells) {
    const Eigen::Vector3f in_order = sum_count.first / static_cast<float>(sum_count.second);
    differing += in_order != pcl_centroids[index++];
  }
  EXPECT_GT(differing, 0u);
}

TEST(VoxelGrid, EdgesFarPointsAndNonFiniteAreAsPcl) {
  Rng random(5);
  for (double offset : {0.0, -2.5, 4.0e5}) {  // 4e5 m: past 2^23 cells of 2 cm
    std::vector<Eigen::Vector3f> points;
    for (int i = 0; i < 20000; ++i) {
      Eigen::Vector3f p(static_cast<float>(random.Uniform(-2, 2) + offset),
                        static_cast<float>(random.Uniform(-2, 2)),
                        static_cast<float>(random.Uniform(0, 2.5)));
      if (i % 3 == 0) p = (p / 0.02f).array().round().matrix() * 0.02f;  // on a cell's edge
      points.push_back(p);
    }
    points[17] = Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 0, 0);
    points[99].z() = std::numeric_limits<float>::infinity();
    EXPECT_TRUE(SameBits(VoxelCentroids(points, 0.02f), PclCentroids(points, 0.02f)))
        << "offset " << offset;
  }
}

TEST(VoxelGrid, TooManyCellsComeBackUnthinnedAsPclDoes) {
  const std::vector<Eigen::Vector3f> points = {{0, 0, 0}, {0, 0, 0}, {3000, 3000, 3000}};
  const std::vector<Eigen::Vector3f> ours = VoxelCentroids(points, 0.005f);
  EXPECT_EQ(ours.size(), 3u);
  EXPECT_TRUE(SameBits(ours, PclCentroids(points, 0.005f)));
}

TEST(VoxelGrid, NothingFiniteGivesNothing) {
  EXPECT_TRUE(VoxelCentroids({}, 0.02f).empty());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(VoxelCentroids({{nan, 0, 0}, {0, nan, 1}}, 0.02f).empty());
}

TEST(FloorToInt, IsTheCastOfStdFloor) {
  Rng random(11);
  for (int i = 0; i < 200000; ++i) {
    const double scale = std::pow(10.0, random.Uniform(-3, 9));  // up to 1e9 < 2^31
    const double t = random.Uniform(-1, 1) * scale;
    EXPECT_EQ(FloorToInt(static_cast<float>(t)),
              static_cast<int>(std::floor(static_cast<float>(t))));
    EXPECT_EQ(FloorToInt(t), static_cast<int>(std::floor(t)));
  }
  for (float t : {0.0f,
                  -0.0f,
                  1.0f,
                  -1.0f,
                  -0.5f,
                  0.5f,
                  -1e-30f,
                  1e-30f,
                  8388607.5f,
                  -8388607.5f,
                  1e9f,
                  -1e9f}) {
    EXPECT_EQ(FloorToInt(t), static_cast<int>(std::floor(t))) << t;
    EXPECT_EQ(FloorToInt(std::nextafter(t, 1.0f)),
              static_cast<int>(std::floor(std::nextafter(t, 1.0f))));
    EXPECT_EQ(FloorToInt(std::nextafter(t, -1.0f)),
              static_cast<int>(std::floor(std::nextafter(t, -1.0f))));
  }
}

}  // namespace
}  // namespace furn
