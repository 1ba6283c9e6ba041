#include "scenes/room_composer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <vector>

#include "core/util/error.h"
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

TEST(RoomComposer, SizeJitterResizesPiecesWithinTheirClassAndTheMeshFollows) {
  const ComposerCatalog catalog = ProceduralComposerCatalog();
  std::map<FurnitureClass, std::pair<Eigen::Vector3d, Eigen::Vector3d>> ranges;
  std::map<std::string, Eigen::Vector3d> own_size;
  for (const auto& item : catalog.furniture) {
    own_size[item.id] = item.size_m;
    auto [it, inserted] = ranges.try_emplace(*item.furniture_class, item.size_m, item.size_m);
    it->second.first = it->second.first.cwiseMin(item.size_m);
    it->second.second = it->second.second.cwiseMax(item.size_m);
  }
  RoomOptions options;
  const RoomLayout plain = ComposeRoom(catalog, options, 5);
  for (const PlacedObject& object : plain.objects) {
    EXPECT_EQ(object.scale, Eigen::Vector3d::Ones()) << "no jitter asked for";
  }
  options.size_jitter = 0.2;
  int resized = 0, anisotropic = 0;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    const RoomLayout room = ComposeRoom(catalog, options, seed);
    for (const PlacedObject& object : room.objects) {
      if (!object.IsTarget()) {
        EXPECT_EQ(object.scale, Eigen::Vector3d::Ones()) << "clutter keeps its size";
        continue;
      }
      const Eigen::Vector3d own = own_size.at(object.model_id);
      EXPECT_TRUE(object.size_m.isApprox(own.cwiseProduct(object.scale), 1e-12));
      const auto& [low, high] = ranges.at(*object.furniture_class);
      for (int axis = 0; axis < 3; ++axis) {
        EXPECT_GE(object.scale[axis], 0.8 - 1e-12);
        EXPECT_LE(object.scale[axis], 1.2 + 1e-12);
        EXPECT_GE(object.size_m[axis], std::min(low[axis], own[axis]) - 1e-12);
        EXPECT_LE(object.size_m[axis], std::max(high[axis], own[axis]) + 1e-12);
      }
      resized += (object.scale - Eigen::Vector3d::Ones()).norm() > 1e-3;
      anisotropic += std::abs(object.scale.x() - object.scale.z()) > 1e-3;
    }
    // The rendered mesh has the jittered size.
    std::map<std::string, std::shared_ptr<const TriangleMesh>> meshes;
    for (const PlacedObject& object : room.objects) {
      const Eigen::Vector3d own =
          object.IsTarget() ? own_size.at(object.model_id) : Eigen::Vector3d(0.4, 0.3, 0.3);
      const Eigen::Vector3f size = own.cast<float>();
      meshes[object.model_id] = std::make_shared<TriangleMesh>(
          MakeBox(Eigen::Vector3f(-size.x() / 2, -size.y() / 2, 0.0f),
                  Eigen::Vector3f(size.x() / 2, size.y() / 2, size.z())));
    }
    const Scene scene = BuildRoomScene(room, meshes);
    const size_t first_object = scene.objects.size() - room.objects.size();
    for (size_t k = 0; k < room.objects.size(); ++k) {
      if (!room.objects[k].IsTarget()) continue;
      const Eigen::Vector3d size =
          BoundingBox(*scene.objects[first_object + k].mesh).Size().cast<double>();
      EXPECT_TRUE(size.isApprox(room.objects[k].size_m, 1e-5)) << size.transpose();
    }
  }
  EXPECT_GT(resized, 50);
  EXPECT_GT(anisotropic, 50);
  options.size_jitter = 0.6;
  EXPECT_THROW(ComposeRoom(catalog, options, 1), InputError);
}

// Surface clutter (issue 69): small pieces on the tops of tables and
// sideboards, at the top's height, inside its footprint, not overlapping each
// other; the pieces on the floor are those of the room without it.
TEST(RoomComposer, SurfaceClutterSitsOnTheTopsOfTablesAndSideboards) {
  const ComposerCatalog catalog = ProceduralComposerCatalog();
  RoomOptions plain_options, options;
  options.surface_clutter = 1;
  int on_top = 0;
  for (uint64_t seed = 1; seed <= 30; ++seed) {
    const RoomLayout plain = ComposeRoom(catalog, plain_options, seed);
    const RoomLayout room = ComposeRoom(catalog, options, seed);
    std::vector<const PlacedObject*> floor_pieces, surface_pieces;
    for (const PlacedObject& object : room.objects)
      (object.z > 0 ? surface_pieces : floor_pieces).push_back(&object);
    ASSERT_EQ(floor_pieces.size(), plain.objects.size()) << "seed " << seed;
    for (size_t k = 0; k < floor_pieces.size(); ++k) {
      EXPECT_EQ(floor_pieces[k]->model_id, plain.objects[k].model_id);
      EXPECT_EQ(floor_pieces[k]->x, plain.objects[k].x);
    }
    for (const PlacedObject* piece : surface_pieces) {
      ++on_top;
      EXPECT_FALSE(piece->IsTarget());
      EXPECT_EQ(piece->model_id, "clutter/box") << "only pieces up to 0.5 m go on tops";
      const PlacedObject* under = nullptr;
      for (const PlacedObject* floor_piece : floor_pieces) {
        const Eigen::Vector2d local =
            Eigen::Rotation2Dd(-floor_piece->yaw) *
            Eigen::Vector2d(piece->x - floor_piece->x, piece->y - floor_piece->y);
        if (std::abs(local.x()) < floor_piece->size_m.x() / 2 &&
            std::abs(local.y()) < floor_piece->size_m.y() / 2)
          under = floor_piece;
      }
      ASSERT_NE(under, nullptr) << "seed " << seed;
      EXPECT_TRUE(under->furniture_class == FurnitureClass::kTable ||
                  under->furniture_class == FurnitureClass::kSideboard);
      EXPECT_DOUBLE_EQ(piece->z, under->size_m.z());
      EXPECT_DOUBLE_EQ(piece->WorldFromObject().translation().z(), under->size_m.z());
      for (const PlacedObject* other : surface_pieces) {
        if (other == piece) continue;
        EXPECT_FALSE(FootprintsOverlap(*piece, *other, 0.01));
      }
    }
  }
  EXPECT_GT(on_top, 20);
  options.surface_clutter = 1.5;
  EXPECT_THROW(ComposeRoom(catalog, options, 1), InputError);
  options = RoomOptions{};
  options.max_clutter_side_m = 0.1;
  EXPECT_THROW(ComposeRoom(catalog, options, 1), InputError);
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
