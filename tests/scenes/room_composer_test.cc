#include "scenes/room_composer.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "scenes/catalog.h"

namespace furn {
namespace {

ComposerCatalog ProceduralComposerCatalog() {
  // The procedural catalog has furniture only; add a few clutter items by hand.
  ComposerCatalog catalog = ComposerCatalog::From(OpenCatalog("procedural:4"));
  catalog.clutter.push_back({"clutter/box", std::nullopt, Eigen::Vector3d(0.4, 0.3, 0.3)});
  catalog.clutter.push_back({"clutter/plant", std::nullopt, Eigen::Vector3d(0.5, 0.5, 1.2)});
  return catalog;
}

TEST(RoomComposer, FootprintsNeverOverlapAndStayInTheRoom) {
  const ComposerCatalog catalog = ProceduralComposerCatalog();
  RoomOptions options;
  int objects = 0, dining_chairs = 0;
  for (uint64_t seed = 1; seed <= 60; ++seed) {
    const RoomLayout room = ComposeRoom(catalog, options, seed);
    ASSERT_GE(room.width_m, options.min_side_m);
    ASSERT_LE(room.width_m, options.max_side_m);
    ASSERT_GE(room.placed_furniture, 1) << "seed " << seed;
    for (size_t i = 0; i < room.objects.size(); ++i) {
      const PlacedObject& a = room.objects[i];
      ++objects;
      const double reach = std::hypot(a.size_m.x(), a.size_m.y()) / 2;
      EXPECT_LE(std::abs(a.x), room.width_m / 2 + 1e-9) << "seed " << seed;
      EXPECT_LE(std::abs(a.y), room.depth_m / 2 + 1e-9) << "seed " << seed;
      (void)reach;
      for (size_t j = i + 1; j < room.objects.size(); ++j) {
        EXPECT_FALSE(FootprintsOverlap(a, room.objects[j], options.clearance_m - 1e-6))
            << "seed " << seed << ": " << a.model_id << " and " << room.objects[j].model_id;
      }
    }
    for (const PlacedObject& a : room.objects) {
      if (a.furniture_class != FurnitureClass::kChair) continue;
      // A chair next to a table faces it: its front (-y of the model) points at the table.
      for (const PlacedObject& t : room.objects) {
        if (t.furniture_class != FurnitureClass::kTable) continue;
        const Eigen::Vector2d to_table(t.x - a.x, t.y - a.y);
        if (to_table.norm() > 1.2) continue;
        const Eigen::Vector2d front = Eigen::Rotation2Dd(a.yaw) * Eigen::Vector2d(0, -1);
        if (front.dot(to_table.normalized()) > 0.9) ++dining_chairs;
      }
    }
  }
  EXPECT_GT(objects, 300);
  EXPECT_GT(dining_chairs, 20) << "chairs should be arranged around tables";
}

TEST(RoomComposer, CamerasAreInFreeSpaceLookingIntoTheRoom) {
  const ComposerCatalog catalog = ProceduralComposerCatalog();
  RoomOptions options;
  options.frames_per_room = 6;
  for (uint64_t seed = 1; seed <= 30; ++seed) {
    const RoomLayout room = ComposeRoom(catalog, options, seed);
    ASSERT_EQ(room.world_from_cameras.size(), 6u);
    for (const Eigen::Isometry3d& camera : room.world_from_cameras) {
      const Eigen::Vector3d p = camera.translation();
      EXPECT_GE(p.z(), options.min_camera_height_m - 1e-9);
      EXPECT_LE(p.z(), options.max_camera_height_m + 1e-9);
      EXPECT_LT(std::abs(p.x()), room.width_m / 2);
      EXPECT_LT(std::abs(p.y()), room.depth_m / 2);
      const Eigen::Vector3d forward = camera.linear().col(2);
      const double pitch_down = std::asin(-forward.z()) * 180 / M_PI;
      EXPECT_GE(pitch_down, options.min_pitch_deg - 1e-6);
      EXPECT_LE(pitch_down, options.max_pitch_deg + 1e-6);
      for (const PlacedObject& object : room.objects) {
        PlacedObject probe;
        probe.x = p.x();
        probe.y = p.y();
        probe.size_m = Eigen::Vector3d(0.1, 0.1, 0);
        EXPECT_FALSE(FootprintsOverlap(probe, object, 0.3))
            << "camera too close to " << object.model_id;
      }
    }
  }
}

TEST(RoomComposer, SameSeedSameRoomDifferentSeedDifferent) {
  const ComposerCatalog catalog = ProceduralComposerCatalog();
  const RoomLayout a = ComposeRoom(catalog, RoomOptions{}, 77),
                   b = ComposeRoom(catalog, RoomOptions{}, 77);
  const RoomLayout c = ComposeRoom(catalog, RoomOptions{}, 78);
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (size_t i = 0; i < a.objects.size(); ++i) {
    EXPECT_EQ(a.objects[i].model_id, b.objects[i].model_id);
    EXPECT_EQ(a.objects[i].x, b.objects[i].x);
    EXPECT_EQ(a.objects[i].yaw, b.objects[i].yaw);
  }
  EXPECT_TRUE(a.world_from_cameras[0].isApprox(b.world_from_cameras[0], 0));
  EXPECT_NE(a.width_m, c.width_m);
}

TEST(RoomComposer, SmallRoomPlacesWhatFitsAndSaysSo) {
  const ComposerCatalog catalog = ProceduralComposerCatalog();
  RoomOptions options;
  options.min_side_m = options.max_side_m = 2.2;
  options.min_furniture = options.max_furniture = 20;
  const RoomLayout room = ComposeRoom(catalog, options, 3);
  EXPECT_EQ(room.requested_furniture, 20);
  EXPECT_LT(room.placed_furniture, 20);
  EXPECT_GE(room.placed_furniture, 1);
}

TEST(RoomComposer, BadRequestsAreRejected) {
  const ComposerCatalog catalog = ProceduralComposerCatalog();
  RoomOptions options;
  options.min_side_m = 9;
  options.max_side_m = 4;
  EXPECT_THROW(ComposeRoom(catalog, options, 1), InputError);
  options = RoomOptions{};
  options.frames_per_room = 0;
  EXPECT_THROW(ComposeRoom(catalog, options, 1), InputError);
  ComposerCatalog empty;
  EXPECT_THROW(ComposeRoom(empty, RoomOptions{}, 1), InputError);
}

TEST(RoomComposer, OverlapTestOnRotatedRectangles) {
  PlacedObject a, b;
  a.size_m = b.size_m = Eigen::Vector3d(1, 1, 1);
  b.x = 1.05;
  EXPECT_FALSE(FootprintsOverlap(a, b, 0.0));
  EXPECT_TRUE(FootprintsOverlap(a, b, 0.1));
  b.yaw = M_PI / 4;  // a diamond reaching 0.707 towards a
  b.x = 1.15;
  EXPECT_TRUE(FootprintsOverlap(a, b, 0.0));
  b.x = 1.25;
  EXPECT_FALSE(FootprintsOverlap(a, b, 0.0));
}

}  // namespace
}  // namespace furn
