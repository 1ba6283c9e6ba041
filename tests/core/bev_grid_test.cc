// The bird's-eye-view rasteriser of the learned vote stage: a known box's
// points, floor, free space and unknown cells land where they belong;
// mirrored images and objects agree. (Targets and decoding:
// bev_box_coder_test.cc.)
#include "core/learned/bev_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace furn {
namespace {

// Camera 1.2 m up at the world origin looking along +x (optical z), level.
Eigen::Isometry3d LevelCamera() {
  Eigen::Matrix3d rotation;
  rotation.col(0) = -Eigen::Vector3d::UnitY();  // image x: right
  rotation.col(1) = -Eigen::Vector3d::UnitZ();  // image y: down
  rotation.col(2) = Eigen::Vector3d::UnitX();   // optical axis: forward
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = Eigen::Vector3d(0, 0, 1.2);
  return pose;
}

// Floor points on a fan in front of the sensor (stopping at the box's
// bearing before it), and the front face of a 0.4 m wide, 0.7 m tall box
// whose front is 2 m ahead, centred 0.5 m to the left.
std::vector<Eigen::Vector3f> Scene() {
  std::vector<Eigen::Vector3f> points;
  for (double u = 0.5; u < 3.0; u += 0.02) {
    for (double v = -1.0; v <= 1.0; v += 0.02) {
      const bool behind_box = u >= 2.0 && v > 0.28 && v < 0.72;
      if (!behind_box) points.emplace_back(u, v, 0.0f);
    }
  }
  for (double v = 0.3; v <= 0.7; v += 0.01) {
    for (double z = 0.05; z <= 0.7; z += 0.01) points.emplace_back(2.0f, v, z);
  }
  return points;
}

TEST(BevGrid, FrameFollowsTheHorizontalViewDirection) {
  const BevFrame frame = BevFrameOf(LevelCamera());
  EXPECT_NEAR(frame.heading, 0, 1e-9);
  const BevGridSpec spec;
  const Eigen::Vector2d cell = frame.CellOf({2.0, 0.5}, spec);
  EXPECT_NEAR(cell.x(), 40, 1e-9);                    // 2 m ahead, 5 cm rows
  EXPECT_NEAR(cell.y(), spec.cols / 2.0 + 10, 1e-9);  // 0.5 m left
  EXPECT_TRUE(frame.WorldOf(cell, spec).isApprox(Eigen::Vector2d(2.0, 0.5)));
  // Pitched down 40 degrees and turned 90 degrees left: heading +90 degrees.
  Eigen::Isometry3d turned = LevelCamera();
  turned.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                    turned.linear() *
                    Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_NEAR(BevFrameOf(turned).heading, M_PI / 2, 1e-9);
}

TEST(BevGrid, BoxFloorFreeAndUnknownCellsWhereTheyBelong) {
  const BevGridSpec spec;
  const Eigen::Isometry3d camera = LevelCamera();
  std::vector<Eigen::Vector3f> camera_points;
  for (const Eigen::Vector3f& p : Scene())
    camera_points.push_back(camera.inverse().cast<float>() * p);
  const BevImage image = RasteriseScan(camera_points, camera, 3.5, spec);
  const BevFrame& frame = image.frame;
  auto cell = [&](double x, double y) {
    const Eigen::Vector2d c = frame.CellOf({x, y}, spec);
    return std::make_pair(static_cast<int>(std::floor(c.x())), static_cast<int>(std::floor(c.y())));
  };
  // The box's face: slices 1..3 (0.03-0.8 m) counted, max height 0.7 m / 2.
  const auto [box_row, box_col] = cell(2.01, 0.51);
  for (int k = 1; k <= 3; ++k) EXPECT_GT(image.At(k, box_row, box_col), 0.5f) << "slice " << k;
  EXPECT_EQ(image.At(4, box_row, box_col), 0.0f);  // nothing 0.8..1.1 m
  EXPECT_NEAR(image.At(6, box_row, box_col), 0.35f, 0.01f);
  EXPECT_EQ(image.At(0, box_row, box_col), 0.0f);  // no floor under the face
  // Floor in front: floor counted, nothing above, seen.
  const auto [floor_row, floor_col] = cell(1.2, -0.4);
  EXPECT_GT(image.At(0, floor_row, floor_col), 0.3f);  // 4 points: log(5) / 4
  for (int k = 1; k <= 6; ++k) EXPECT_EQ(image.At(k, floor_row, floor_col), 0.0f);
  EXPECT_EQ(image.At(7, floor_row, floor_col), 1.0f);
  // Free space in front of the box on its bearing: seen, nothing above the floor.
  const auto [free_row, free_col] = cell(1.5, 0.38);
  EXPECT_EQ(image.At(7, free_row, free_col), 1.0f);
  for (int k = 1; k <= 6; ++k) EXPECT_EQ(image.At(k, free_row, free_col), 0.0f);
  // Behind the box: unknown (not seen), empty.
  const auto [hidden_row, hidden_col] = cell(2.6, 0.5);
  EXPECT_EQ(image.At(7, hidden_row, hidden_col), 0.0f);
  EXPECT_EQ(image.At(0, hidden_row, hidden_col), 0.0f);
  // Outside the field of points (far right, nothing returned there): unknown.
  const auto [side_row, side_col] = cell(0.5, -1.5);
  EXPECT_EQ(image.At(7, side_row, side_col), 0.0f);
  // Beyond the range given: not rasterised.
  const BevImage near = RasteriseScan(camera_points, camera, 1.5, spec);
  EXPECT_EQ(near.At(1, box_row, box_col), 0.0f);
}

TEST(BevGrid, MirroredImageIsTheImageOfMirroredPoints) {
  const BevGridSpec spec;
  const Eigen::Isometry3d camera = LevelCamera();
  std::vector<Eigen::Vector3f> points = Scene(), mirrored;
  for (const Eigen::Vector3f& p : points) mirrored.emplace_back(p.x(), -p.y(), p.z());
  const BevFrame frame = BevFrameOf(camera);
  const Eigen::Vector3f sensor = camera.translation().cast<float>();
  const BevImage a = RasteriseBev(points, sensor, frame, spec).Mirrored();
  const BevImage b = RasteriseBev(mirrored, sensor, frame, spec);
  int differing = 0;
  for (size_t i = 0; i < a.values.size(); ++i)
    differing += std::abs(a.values[i] - b.values[i]) > 1e-6;
  // Points exactly on a cell edge may fall on either side once mirrored.
  EXPECT_LT(differing, static_cast<int>(a.values.size() / 200));
}

// Mirroring (augmentation): a chair facing the camera's left, mirrored, faces
// its right; its centre moves to the other side; a table keeps its axis
// reflected. Fronts face -y (docs/cad-models.md), so yaw' = pi - yaw in the
// grid's frame.
TEST(BevGrid, MirroredObjectsFaceTheMirroredWay) {
  BevFrame frame = BevFrameOf(LevelCamera());
  // A chair 2 m ahead, 0.4 m left, turned so its front (-y) faces the
  // camera's left (+y of the world here): yaw pi.
  const BevObject chair{{2.0, 0.4, M_PI, 0.5, 0.5}, FurnitureClass::kChair};
  const BevObject mirrored = MirroredObject(chair, frame);
  EXPECT_TRUE(mirrored.Centre().isApprox(Eigen::Vector2d(2.0, -0.4)));
  const Eigen::Vector2d front = Eigen::Rotation2Dd(mirrored.yaw) * Eigen::Vector2d(0, -1);
  EXPECT_NEAR(front.y(), -1, 1e-9) << "faces the camera's right once mirrored";
  // Twice mirrored is the object itself; under another heading too.
  frame = BevFrameOf(Eigen::Isometry3d(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ())) *
                     LevelCamera());
  const BevObject table{{1.3, -0.9, 0.25, 1.2, 0.8}, FurnitureClass::kTable};
  const BevObject twice = MirroredObject(MirroredObject(table, frame), frame);
  EXPECT_TRUE(twice.Centre().isApprox(table.Centre()));
  EXPECT_NEAR(std::remainder(twice.yaw - table.yaw, 2 * M_PI), 0, 1e-9);
  // Its cell is the image's mirrored column.
  const BevGridSpec spec;
  const Eigen::Vector2d a = frame.CellOf(table.Centre(), spec);
  const Eigen::Vector2d b = frame.CellOf(MirroredObject(table, frame).Centre(), spec);
  EXPECT_NEAR(a.x(), b.x(), 1e-9);
  EXPECT_NEAR(a.y(), spec.cols - b.y(), 1e-9);
}

// The "seen" channel without per-point trigonometry (a rough arctangent
// moved to the bin whose edges hold the point) is the channel atan2 and
// hypot give: written here from its definition, on random points all
// around a sensor at an odd heading, half of them in view.
TEST(BevGrid, SeenChannelIsThatOfTheExactBearings) {
  BevGridSpec spec;
  BevFrame frame;
  frame.origin = Eigen::Vector2d(0.3, -0.2);
  frame.heading = 2.1;
  frame.forward = Eigen::Vector2d(std::cos(frame.heading), std::sin(frame.heading));
  const Eigen::Vector3f sensor(0.3f, -0.2f, 1.2f);
  std::vector<Eigen::Vector3f> points;
  uint64_t state = 12345;
  auto uniform = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  };
  for (int i = 0; i < 20000; ++i) {
    const double bearing = (i % 2 ? 0.6 : M_PI) * (2 * uniform() - 1) + frame.heading;
    const double range = 0.2 + 4 * uniform();
    points.emplace_back(sensor.x() + range * std::cos(bearing),
                        sensor.y() + range * std::sin(bearing),
                        static_cast<float>(1.5 * uniform()));
  }
  // Exactly on the axes and the diagonals, where octants meet.
  for (const Eigen::Vector2d& d : {Eigen::Vector2d(1, 0),
                                   Eigen::Vector2d(0, 1),
                                   Eigen::Vector2d(-1, 0),
                                   Eigen::Vector2d(0, -1),
                                   Eigen::Vector2d(1, 1),
                                   Eigen::Vector2d(-1, -1)})
    points.emplace_back(sensor.x() + 2 * d.x(), sensor.y() + 2 * d.y(), 0.5f);
  const BevImage image = RasteriseBev(points, sensor, frame, spec);

  constexpr int kBins = 720;
  auto bin_of = [](double u, double v) {
    const int bin = static_cast<int>((std::atan2(v, u) + M_PI) / (2 * M_PI) * kBins);
    return std::clamp(bin, 0, kBins - 1);
  };
  std::vector<double> farthest(kBins, 0.0);
  const Eigen::Vector2d left = frame.Left();
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector2d d = p.head<2>().cast<double>() - sensor.head<2>().cast<double>();
    const double u = d.dot(frame.forward), v = d.dot(left);
    farthest[bin_of(u, v)] = std::max(farthest[bin_of(u, v)], std::hypot(u, v));
  }
  int seen = 0;
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      const Eigen::Vector2d d =
          frame.WorldOf({r + 0.5, c + 0.5}, spec) - sensor.head<2>().cast<double>();
      const double u = d.dot(frame.forward), v = d.dot(left);
      const float expected = std::hypot(u, v) < farthest[bin_of(u, v)] ? 1.0f : 0.0f;
      ASSERT_EQ(image.At(kBevSeenChannel, r, c), expected) << "cell " << r << ", " << c;
      seen += expected > 0;
    }
  }
  EXPECT_GT(seen, spec.rows * spec.cols / 4);
}

// A scan is rasterised point by point (no copy in the world frame): the
// image of its finite points within range, moved into the world, as
// RasteriseBev makes it; a cell of more points than the counts' look-up
// table holds gets log(1 + count) / 4 all the same.
TEST(BevGrid, RasteriseScanIsTheImageOfItsPointsInRange) {
  const Eigen::Isometry3d pose = LevelCamera() * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX());
  std::vector<Eigen::Vector3f> camera;
  uint64_t state = 99;
  auto uniform = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<float>(static_cast<double>(state >> 11) / 9007199254740992.0);
  };
  for (int i = 0; i < 30000; ++i)
    camera.emplace_back(4 * uniform() - 2, 2 * uniform() - 1, 5 * uniform());
  for (int i = 0; i < 5000; ++i) camera.emplace_back(0.0f, 0.0f, 2.0f);  // one cell
  const float nan = std::numeric_limits<float>::quiet_NaN();
  camera.emplace_back(nan, 0.0f, 1.0f);
  camera.emplace_back(0.0f, 0.0f, 0.0f);
  camera.emplace_back(0.0f, 0.0f, std::numeric_limits<float>::infinity());
  const double range_m = 3.6;
  const BevGridSpec spec;
  const BevImage image = RasteriseScan(camera, pose, range_m, spec);

  const Eigen::Matrix3f rotation = pose.linear().cast<float>();
  const Eigen::Vector3f translation = pose.translation().cast<float>();
  std::vector<Eigen::Vector3f> world;
  for (const Eigen::Vector3f& p : camera) {
    if (p.allFinite() && p.squaredNorm() > 0 && p.squaredNorm() <= range_m * range_m)
      world.push_back(rotation * p + translation);
  }
  ASSERT_GT(world.size(), 10000u);
  const BevImage expected = RasteriseBev(world, translation, BevFrameOf(pose), spec);
  ASSERT_EQ(image.values.size(), expected.values.size());
  EXPECT_TRUE(image.values == expected.values);

  const Eigen::Vector3f dense = rotation * Eigen::Vector3f(0, 0, 2) + translation;
  const Eigen::Vector2d cell = image.frame.CellOf(dense.head<2>().cast<double>(), spec);
  float most = 0;
  for (int k = 0; k < kBevTopChannel; ++k)
    most = std::max(most,
                    image.At(k,
                             static_cast<int>(std::floor(cell.x())),
                             static_cast<int>(std::floor(cell.y()))));
  EXPECT_GE(most, std::log1p(5000.0f) / 4);
}

TEST(BevGrid, SpecChecksNameTheRule) {
  BevGridSpec spec;
  spec.rows = 70;
  try {
    spec.Check();
    FAIL() << "rows 70 accepted";
  } catch (const std::exception& error) {
    EXPECT_NE(std::string(error.what()).find("multiple of 8"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace furn
