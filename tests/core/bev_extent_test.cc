// The extent fit of learned detections: a table whose network box is off
// along its length moves to the surface's two seen ends; an end the scan did
// not see keeps the network's size from the seen one; a lower neighbour does
// not join the surface; nothing moves without a surface; the classes and the
// options' rules.
#include "core/learned/bev_extent.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/util/error.h"

namespace furn {
namespace {

// A rectangle of points at height z, every 1 cm.
void AddRectangle(const FurnitureBox& box, double z, std::vector<Eigen::Vector3f>* points) {
  const Eigen::Rotation2Dd rotation(box.yaw);
  for (double a = -box.width / 2; a <= box.width / 2; a += 0.01) {
    for (double b = -box.depth / 2; b <= box.depth / 2; b += 0.01) {
      const Eigen::Vector2d xy = Eigen::Vector2d(box.x, box.y) + rotation * Eigen::Vector2d(a, b);
      points->emplace_back(
          static_cast<float>(xy.x()), static_cast<float>(xy.y()), static_cast<float>(z));
    }
  }
}

// A sensor at (0, 0, 1.2) looking along +x over a floor seen to 3.5 m, with
// the given surfaces.
BevImage Scan(const std::vector<std::pair<FurnitureBox, double>>& surfaces) {
  std::vector<Eigen::Vector3f> points;
  AddRectangle({1.75, 0, 0, 3.5, 4.8}, 0.0, &points);  // the floor
  for (const auto& [box, z] : surfaces) AddRectangle(box, z, &points);
  BevGridSpec spec;
  return RasteriseBev(points, Eigen::Vector3f(0, 0, 1.2f), BevFrame{}, spec);
}

const FurnitureBox kTable{2.0, 0.3, 0.4, 2.0, 0.9};

// The network's box: right yaw, 25 cm off along the length, too short.
FurnitureBox NetworkBox() {
  FurnitureBox box = kTable;
  box.x += 0.25 * std::cos(kTable.yaw);
  box.y += 0.25 * std::sin(kTable.yaw);
  box.width = 1.4;
  box.depth = 0.8;
  return box;
}

VisibilityTest ImageVisibility(const BevImage& image) {
  return [&image](const Eigen::Vector3d& world) { return BevVisibility(image, world); };
}

Eigen::Vector2d TableAxis() { return {std::cos(kTable.yaw), std::sin(kTable.yaw)}; }

// Only the near half of the top returned points.
BevImage NearHalfScan() {
  FurnitureBox near_half = kTable;
  near_half.width = 1.0;
  near_half.x -= 0.5 * TableAxis().x();
  near_half.y -= 0.5 * TableAxis().y();
  return Scan({{near_half, 0.75}});
}

// The image's own test, and beyond the table's middle nothing known.
VisibilityTest FarHalfUnknown(const BevImage& image) {
  return [&image](const Eigen::Vector3d& world) {
    const double along = (world.head<2>() - Eigen::Vector2d(kTable.x, kTable.y)).dot(TableAxis());
    return along > 0 ? Visibility::kUnknown : BevVisibility(image, world);
  };
}

TEST(ExtentFit, BothEndsSeenPlaceTheCentreBetweenThem) {
  const BevImage image = Scan({{kTable, 0.75}});
  const ExtentFit fit = FitExtent(image, NetworkBox(), ImageVisibility(image), ExtentFitOptions{});
  EXPECT_TRUE(fit.moved);
  EXPECT_NEAR(fit.top_m, 0.75, 0.01);
  for (bool seen : fit.edge_seen) EXPECT_TRUE(seen);
  EXPECT_NEAR(fit.box.x, kTable.x, 0.03);
  EXPECT_NEAR(fit.box.y, kTable.y, 0.03);
  EXPECT_NEAR(fit.box.width, kTable.width, 0.07);
  EXPECT_NEAR(fit.box.depth, kTable.depth, 0.07);
  EXPECT_DOUBLE_EQ(fit.box.yaw, kTable.yaw);
}

TEST(ExtentFit, AnUnseenEndKeepsTheNetworksSizeFromTheSeenOne) {
  const BevImage image = NearHalfScan();
  const Eigen::Vector2d axis = TableAxis();
  const VisibilityTest visibility = FarHalfUnknown(image);
  const ExtentFit fit = FitExtent(image, NetworkBox(), visibility, ExtentFitOptions{});
  EXPECT_TRUE(fit.moved);
  EXPECT_FALSE(fit.edge_seen[0]);  // the far (+width) end
  EXPECT_TRUE(fit.edge_seen[1]);
  // The near end at -1.0 m along the table, the network's 1.4 m from it.
  const double along =
      (Eigen::Vector2d(fit.box.x, fit.box.y) - Eigen::Vector2d(kTable.x, kTable.y)).dot(axis);
  EXPECT_NEAR(along, -1.0 + 0.7, 0.04);
  EXPECT_NEAR(fit.box.width, 1.4, 1e-9);
}

TEST(ExtentFit, WithoutOneEdgeMovesOnlyAxesSeenWholeMove) {
  const BevImage image = NearHalfScan();
  const Eigen::Vector2d axis = TableAxis();
  const VisibilityTest visibility = FarHalfUnknown(image);
  ExtentFitOptions options;
  options.one_edge_moves = false;
  const FurnitureBox network = NetworkBox();
  const ExtentFit fit = FitExtent(image, network, visibility, options);
  // Along the length (one end seen) nothing moved; across it (both seen) the
  // box spans the top's 0.9 m.
  const Eigen::Vector2d moved = Eigen::Vector2d(fit.box.x - network.x, fit.box.y - network.y);
  EXPECT_NEAR(moved.dot(axis), 0, 1e-9);
  EXPECT_NEAR(fit.box.width, network.width, 1e-9);
  EXPECT_NEAR(fit.box.depth, kTable.depth, 0.07);
}

TEST(ExtentFit, ALowerNeighbourDoesNotJoinTheTop) {
  // A chair's seat (0.45 m) touching the table's +width end.
  const FurnitureBox seat{kTable.x + 1.25 * std::cos(kTable.yaw),
                          kTable.y + 1.25 * std::sin(kTable.yaw),
                          kTable.yaw,
                          0.5,
                          0.5};
  const BevImage image = Scan({{kTable, 0.75}, {seat, 0.45}});
  const ExtentFit fit = FitExtent(image, NetworkBox(), ImageVisibility(image), ExtentFitOptions{});
  EXPECT_TRUE(fit.edge_seen[0]);  // free at the top's height above the seat
  EXPECT_NEAR(fit.box.x, kTable.x, 0.03);
  EXPECT_NEAR(fit.box.width, kTable.width, 0.07);
}

TEST(ExtentFit, NothingMovesWithoutASurface) {
  const BevImage image = Scan({});
  const FurnitureBox box = NetworkBox();
  const ExtentFit fit = FitExtent(image, box, ImageVisibility(image), ExtentFitOptions{});
  EXPECT_FALSE(fit.moved);
  EXPECT_EQ(fit.surface_cells, 0);
  EXPECT_DOUBLE_EQ(fit.box.x, box.x);
  EXPECT_DOUBLE_EQ(fit.box.width, box.width);
}

TEST(ExtentFit, ClassesAndOptions) {
  EXPECT_TRUE(FitsExtent(ExtentFitClasses::kLarge, FurnitureClass::kTable));
  EXPECT_TRUE(FitsExtent(ExtentFitClasses::kLarge, FurnitureClass::kSideboard));
  EXPECT_FALSE(FitsExtent(ExtentFitClasses::kLarge, FurnitureClass::kChair));
  EXPECT_TRUE(FitsExtent(ExtentFitClasses::kAll, FurnitureClass::kChair));
  EXPECT_FALSE(FitsExtent(ExtentFitClasses::kNone, FurnitureClass::kTable));
  EXPECT_TRUE(FitsExtent(ExtentFitClasses::kTables, FurnitureClass::kTable));
  EXPECT_FALSE(FitsExtent(ExtentFitClasses::kTables, FurnitureClass::kSideboard));
  ExtentFitOptions options;
  options.window_scale = 0.5;
  EXPECT_THROW(options.Check(), InputError);
  options = ExtentFitOptions{};
  options.min_free = 0;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace furn
