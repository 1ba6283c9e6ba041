// Oriented-box overlap against closed forms: identical boxes, a shift along
// one side, a square turned by 45 degrees in itself (an octagon), disjoint,
// nested, and a z-only offset; BEV against 3-D.
#include <gtest/gtest.h>

#include <cmath>

#include "core/geometry/box_iou.h"

namespace furn {
namespace {

OrientedBox Box(double x, double y, double z, double sx, double sy, double sz, double yaw = 0) {
  OrientedBox box;
  box.centre = Eigen::Vector3d(x, y, z);
  box.size = Eigen::Vector3d(sx, sy, sz);
  box.yaw = yaw;
  return box;
}

TEST(BoxIou, IdenticalBoxesOverlapWhollyAtAnyYaw) {
  for (double yaw : {0.0, 0.3, M_PI / 2, -2.0}) {
    const OrientedBox a = Box(1, 2, 0.5, 1.2, 0.8, 1.0, yaw);
    EXPECT_NEAR(Iou3d(a, a), 1.0, 1e-12);
    EXPECT_NEAR(BevIou(a, a), 1.0, 1e-12);
  }
}

TEST(BoxIou, AShiftAlongOneSide) {
  // 2 x 1 x 1 boxes, one shifted by 0.5 along x: intersection 1.5, union 2.5.
  const OrientedBox a = Box(0, 0, 0.5, 2, 1, 1), b = Box(0.5, 0, 0.5, 2, 1, 1);
  EXPECT_NEAR(Iou3d(a, b), 1.5 / 2.5, 1e-12);
  EXPECT_NEAR(BevIou(a, b), 1.5 / 2.5, 1e-12);
  // The same boxes turned together keep their overlap.
  const OrientedBox c = Box(0, 0, 0.5, 2, 1, 1, 0.7);
  const OrientedBox d = Box(0.5 * std::cos(0.7), 0.5 * std::sin(0.7), 0.5, 2, 1, 1, 0.7);
  EXPECT_NEAR(Iou3d(c, d), 0.6, 1e-12);
}

TEST(BoxIou, ASquareTurnedBy45DegreesInItself) {
  // Unit squares on one centre, one turned by 45 degrees: the intersection is
  // the regular octagon of inradius 1/2, area 2 (sqrt(2) - 1).
  const OrientedBox a = Box(0, 0, 0, 1, 1, 2), b = Box(0, 0, 0, 1, 1, 2, M_PI / 4);
  const double octagon = 2 * (std::sqrt(2.0) - 1);
  EXPECT_NEAR(FootprintIntersectionArea(a, b), octagon, 1e-12);
  EXPECT_NEAR(BevIou(a, b), octagon / (2 - octagon), 1e-12);
  EXPECT_NEAR(Iou3d(a, b), octagon / (2 - octagon), 1e-12);  // same z span
}

TEST(BoxIou, DisjointNestedAndStackedBoxes) {
  EXPECT_EQ(Iou3d(Box(0, 0, 0.5, 1, 1, 1), Box(3, 0, 0.5, 1, 1, 1)), 0.0);
  EXPECT_EQ(BevIou(Box(0, 0, 0.5, 1, 1, 1), Box(0, 1.0001, 0.5, 1, 1, 1)), 0.0);
  // A 1 m cube inside a 2 m cube: 1/8.
  EXPECT_NEAR(Iou3d(Box(0, 0, 1, 2, 2, 2), Box(0.2, -0.3, 0.8, 1, 1, 1, 0.4)), 1.0 / 8, 1e-12);
  EXPECT_NEAR(BevIou(Box(0, 0, 1, 2, 2, 2), Box(0.2, -0.3, 0.8, 1, 1, 1, 0.4)), 1.0 / 4, 1e-12);
  // The same footprint, z spans overlapping by half: BEV 1, 3-D 1/3.
  const OrientedBox low = Box(0, 0, 0.5, 1, 1, 1), high = Box(0, 0, 1.0, 1, 1, 1);
  EXPECT_NEAR(BevIou(low, high), 1.0, 1e-12);
  EXPECT_NEAR(Iou3d(low, high), 0.5 / 1.5, 1e-12);
  // Empty boxes overlap nothing.
  EXPECT_EQ(Iou3d(Box(0, 0, 0, 0, 1, 1), low), 0.0);
  EXPECT_EQ(BevIou(Box(0, 0, 0, 1, 0, 1), low), 0.0);
}

TEST(BoxIou, SymmetricAndBoundedOnRandomBoxes) {
  uint64_t state = 12345;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / static_cast<double>(1ull << 53);
  };
  for (int k = 0; k < 2000; ++k) {
    const OrientedBox a =
        Box(next(), next(), next(), 0.1 + next(), 0.1 + next(), 0.1 + next(), 6 * next());
    const OrientedBox b =
        Box(next(), next(), next(), 0.1 + next(), 0.1 + next(), 0.1 + next(), 6 * next());
    const double ab = Iou3d(a, b), ba = Iou3d(b, a);
    EXPECT_NEAR(ab, ba, 1e-9);
    EXPECT_GE(ab, 0.0);
    EXPECT_LE(ab, BevIou(a, b) + 1e-12);  // z can only take away
  }
}

}  // namespace
}  // namespace furn
