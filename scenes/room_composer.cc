#include "scenes/room_composer.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "core/util/error.h"
#include "core/util/random.h"
#include "scenes/catalog.h"

namespace furn {
namespace {

constexpr double kWallThickness = 0.1;
constexpr int kPlacementAttempts = 60;

// Corners of an object's footprint in the world, widened by `margin`.
std::array<Eigen::Vector2d, 4> FootprintCorners(const PlacedObject& object, double margin) {
  const double hx = object.size_m.x() / 2 + margin, hy = object.size_m.y() / 2 + margin;
  const Eigen::Rotation2Dd rotation(object.yaw);
  const Eigen::Vector2d centre(object.x, object.y);
  return {centre + rotation * Eigen::Vector2d(-hx, -hy),
          centre + rotation * Eigen::Vector2d(hx, -hy),
          centre + rotation * Eigen::Vector2d(hx, hy),
          centre + rotation * Eigen::Vector2d(-hx, hy)};
}

bool InsideRoom(const PlacedObject& object, const RoomLayout& room, double margin) {
  for (const Eigen::Vector2d& corner : FootprintCorners(object, 0)) {
    if (std::abs(corner.x()) > room.width_m / 2 - margin ||
        std::abs(corner.y()) > room.depth_m / 2 - margin) {
      return false;
    }
  }
  return true;
}

bool Fits(const PlacedObject& candidate, const RoomLayout& room, double clearance) {
  if (!InsideRoom(candidate, room, 0.01)) return false;
  return std::none_of(room.objects.begin(), room.objects.end(), [&](const PlacedObject& other) {
    return FootprintsOverlap(candidate, other, clearance);
  });
}

const ComposerCatalog::Item* PickOfClass(const ComposerCatalog& catalog,
                                         FurnitureClass wanted,
                                         Rng* rng) {
  std::vector<const ComposerCatalog::Item*> matching;
  for (const auto& item : catalog.furniture) {
    if (item.furniture_class == wanted) matching.push_back(&item);
  }
  if (matching.empty()) return nullptr;
  return matching[rng->UniformInt(0, static_cast<int64_t>(matching.size()) - 1)];
}

PlacedObject MakeObject(const ComposerCatalog::Item& item, double x, double y, double yaw) {
  PlacedObject object;
  object.model_id = item.id;
  object.furniture_class = item.furniture_class;
  object.size_m = item.size_m;
  object.scale = item.scale;
  object.x = x;
  object.y = y;
  object.yaw = yaw;
  return object;
}

// Draws the size jitter of RoomOptions::size_jitter: per axis a factor in
// [1 - j, 1 + j], the result kept within the sizes the catalog has of the class
// (or the model's own size, where that lies outside them).
class SizeJitter {
 public:
  SizeJitter(const ComposerCatalog& catalog, double jitter) : jitter_(jitter) {
    for (const ComposerCatalog::Item& item : catalog.furniture) {
      auto [it, inserted] = ranges_.try_emplace(*item.furniture_class, item.size_m, item.size_m);
      if (inserted) continue;
      it->second.first = it->second.first.cwiseMin(item.size_m);
      it->second.second = it->second.second.cwiseMax(item.size_m);
    }
  }

  // `item` resized; no random draw when the jitter is 0.
  ComposerCatalog::Item Apply(const ComposerCatalog::Item& item, Rng* rng) const {
    if (jitter_ <= 0 || !item.furniture_class) return item;
    const auto& [low, high] = ranges_.at(*item.furniture_class);
    ComposerCatalog::Item resized = item;
    for (int axis = 0; axis < 3; ++axis) {
      const double drawn = item.size_m[axis] * rng->Uniform(1 - jitter_, 1 + jitter_);
      resized.size_m[axis] = std::clamp(
          drawn, std::min(low[axis], item.size_m[axis]), std::max(high[axis], item.size_m[axis]));
      resized.scale[axis] = item.scale[axis] * resized.size_m[axis] / item.size_m[axis];
    }
    return resized;
  }

 private:
  double jitter_;
  std::map<FurnitureClass, std::pair<Eigen::Vector3d, Eigen::Vector3d>> ranges_;
};

// Yaw that turns the model's front (-y in the model frame) towards `direction`.
double YawFacing(const Eigen::Vector2d& direction) {
  return std::atan2(direction.x(), -direction.y());
}

// Tries random free-standing poses; true when one fits.
bool PlaceFreeStanding(const ComposerCatalog::Item& item,
                       RoomLayout* room,
                       double clearance,
                       Rng* rng) {
  for (int attempt = 0; attempt < kPlacementAttempts; ++attempt) {
    const double yaw = rng->Bernoulli(0.5)
                           ? rng->UniformInt(0, 3) * M_PI / 2 + rng->Uniform(-0.2, 0.2)
                           : rng->Uniform(0, 2 * M_PI);
    PlacedObject object = MakeObject(item,
                                     rng->Uniform(-room->width_m / 2, room->width_m / 2),
                                     rng->Uniform(-room->depth_m / 2, room->depth_m / 2),
                                     yaw);
    if (Fits(object, *room, clearance)) {
      room->objects.push_back(object);
      return true;
    }
  }
  return false;
}

// Back against one of the four walls, front into the room.
bool PlaceAgainstWall(const ComposerCatalog::Item& item,
                      RoomLayout* room,
                      double clearance,
                      Rng* rng) {
  for (int attempt = 0; attempt < kPlacementAttempts; ++attempt) {
    const int wall =
        static_cast<int>(rng->UniformInt(0, 3));  // 0 north (+y), 1 east, 2 south, 3 west
    const double yaw = wall * (-M_PI / 2);        // yaw 0: back (+y) to the north wall
    const double gap = 0.02 + item.size_m.y() / 2;
    const double along = rng->Uniform(-0.5, 0.5);
    double x = 0, y = 0;
    if (wall == 0 || wall == 2) {
      x = along * (room->width_m - item.size_m.x());
      y = (wall == 0 ? 1 : -1) * (room->depth_m / 2 - gap);
    } else {
      y = along * (room->depth_m - item.size_m.x());
      x = (wall == 1 ? 1 : -1) * (room->width_m / 2 - gap);
    }
    PlacedObject object = MakeObject(item, x, y, yaw);
    if (Fits(object, *room, clearance)) {
      room->objects.push_back(object);
      return true;
    }
  }
  return false;
}

// Small clutter on the tops of a share of the tables and sideboards: one to
// three pieces each, inside the top's footprint, not overlapping each other.
constexpr double kSurfaceItemSideM = 0.5;
void PlaceOnSurfaces(const ComposerCatalog& catalog, double share, RoomLayout* room, Rng* rng) {
  std::vector<const ComposerCatalog::Item*> small;
  for (const ComposerCatalog::Item& item : catalog.clutter) {
    if (item.size_m.maxCoeff() <= kSurfaceItemSideM) small.push_back(&item);
  }
  if (small.empty()) return;
  const size_t pieces = room->objects.size();  // the tops of these only
  for (size_t i = 0; i < pieces; ++i) {
    const PlacedObject surface = room->objects[i];  // a copy: the vector grows below
    if (surface.furniture_class != FurnitureClass::kTable &&
        surface.furniture_class != FurnitureClass::kSideboard) {
      continue;
    }
    if (!rng->Bernoulli(share)) continue;
    const size_t wanted = static_cast<size_t>(rng->UniformInt(1, 3));
    std::vector<PlacedObject> on_top;
    for (int attempt = 0; attempt < kPlacementAttempts && on_top.size() < wanted; ++attempt) {
      const ComposerCatalog::Item& item =
          *small[rng->UniformInt(0, static_cast<int64_t>(small.size()) - 1)];
      // Any yaw keeps the piece within its footprint's circumscribed circle.
      const double radius = item.size_m.head<2>().norm() / 2 + 0.02;
      const double hx = surface.size_m.x() / 2 - radius, hy = surface.size_m.y() / 2 - radius;
      if (hx <= 0 || hy <= 0) continue;
      const Eigen::Vector2d place =
          Eigen::Vector2d(surface.x, surface.y) +
          Eigen::Rotation2Dd(surface.yaw) *
              Eigen::Vector2d(rng->Uniform(-hx, hx), rng->Uniform(-hy, hy));
      PlacedObject object = MakeObject(item, place.x(), place.y(), rng->Uniform(0, 2 * M_PI));
      object.z = surface.size_m.z();
      const bool free = std::none_of(on_top.begin(), on_top.end(), [&](const PlacedObject& other) {
        return FootprintsOverlap(object, other, 0.02);
      });
      if (free) on_top.push_back(object);
    }
    room->objects.insert(room->objects.end(), on_top.begin(), on_top.end());
  }
}

// A table with chairs at its sides, facing it. Returns how many pieces it placed.
int PlaceDiningGroup(const ComposerCatalog& catalog,
                     const SizeJitter& jitter,
                     int budget,
                     RoomLayout* room,
                     double clearance,
                     Rng* rng) {
  const ComposerCatalog::Item* table = PickOfClass(catalog, FurnitureClass::kTable, rng);
  if (table == nullptr || !PlaceFreeStanding(jitter.Apply(*table, rng), room, clearance, rng))
    return 0;
  const PlacedObject placed_table = room->objects.back();
  int placed = 1;
  const ComposerCatalog::Item* picked_chair = PickOfClass(catalog, FurnitureClass::kChair, rng);
  if (picked_chair == nullptr) return placed;
  const ComposerCatalog::Item resized_chair = jitter.Apply(*picked_chair, rng);
  const ComposerCatalog::Item* chair = &resized_chair;
  // Sides of the table in its own frame: -y, +y, -x, +x, in random order.
  std::vector<int> sides = {0, 1, 2, 3};
  std::shuffle(sides.begin(), sides.end(), rng->engine());
  for (int side : sides) {
    if (placed >= budget) break;
    const bool along_y = side < 2;
    const double sign = side % 2 == 0 ? -1 : 1;
    const double reach = (along_y ? placed_table.size_m.y() : placed_table.size_m.x()) / 2 +
                         chair->size_m.y() / 2 + clearance + 0.02;
    const Eigen::Vector2d offset_local =
        along_y ? Eigen::Vector2d(0, sign * reach) : Eigen::Vector2d(sign * reach, 0);
    const Eigen::Vector2d offset = Eigen::Rotation2Dd(placed_table.yaw) * offset_local;
    PlacedObject seat = MakeObject(*chair,
                                   placed_table.x + offset.x(),
                                   placed_table.y + offset.y(),
                                   YawFacing(-offset) + rng->Uniform(-0.15, 0.15));
    if (Fits(seat, *room, clearance)) {
      room->objects.push_back(seat);
      ++placed;
    }
  }
  return placed;
}

// Cameras: in free space (0.35 m from every footprint and wall), looking at a
// target piece from at least 1 m, or at the room centre; `camera_zone` is
// the spot kept free where a camera surely fits.
void PlaceCameras(const PlacedObject& camera_zone,
                  const RoomOptions& options,
                  RoomLayout* room,
                  Rng* rng) {
  for (int frame = 0; frame < options.frames_per_room; ++frame) {
    for (int attempt = 0; attempt < 200; ++attempt) {
      PlacedObject probe;
      probe.size_m = Eigen::Vector3d(0.1, 0.1, 0);
      if (attempt < 100) {
        probe.x = rng->Uniform(-room->width_m / 2 + 0.35, room->width_m / 2 - 0.35);
        probe.y = rng->Uniform(-room->depth_m / 2 + 0.35, room->depth_m / 2 - 0.35);
      } else {  // inside the zone kept free for cameras
        probe.x = camera_zone.x + rng->Uniform(-0.05, 0.05);
        probe.y = camera_zone.y + rng->Uniform(-0.05, 0.05);
      }
      if (!Fits(probe, *room, 0.35)) continue;
      Eigen::Vector2d target(0, 0);
      std::vector<const PlacedObject*> targets;
      for (const PlacedObject& object : room->objects) {
        if (object.IsTarget() && std::hypot(object.x - probe.x, object.y - probe.y) > 1.0)
          targets.push_back(&object);
      }
      if (!targets.empty()) {
        const PlacedObject* chosen =
            targets[rng->UniformInt(0, static_cast<int64_t>(targets.size()) - 1)];
        target = Eigen::Vector2d(chosen->x, chosen->y);
      }
      Eigen::Vector2d direction = target - Eigen::Vector2d(probe.x, probe.y);
      if (direction.norm() < 0.5) direction = Eigen::Vector2d(-probe.x, -probe.y);
      if (direction.norm() < 1e-6) direction = Eigen::Vector2d(0, 1);
      const double heading = std::atan2(direction.y(), direction.x()) + rng->Uniform(-0.3, 0.3);
      const double pitch = rng->Uniform(options.min_pitch_deg, options.max_pitch_deg) * M_PI / 180;
      const double height = rng->Uniform(options.min_camera_height_m, options.max_camera_height_m);
      const Eigen::Vector3d forward(std::cos(heading) * std::cos(pitch),
                                    std::sin(heading) * std::cos(pitch),
                                    -std::sin(pitch));
      room->world_from_cameras.push_back(
          LookAlong(Eigen::Vector3d(probe.x, probe.y, height), forward));
      break;
    }
  }
}

}  // namespace

void RoomOptions::Check() const {
  Require(min_side_m >= 2 && max_side_m >= min_side_m && max_side_m <= 30,
          "room sides must satisfy 2 <= min_side_m <= max_side_m <= 30 (got " +
              std::to_string(min_side_m) + ", " + std::to_string(max_side_m) + ")");
  Require(min_furniture >= 0 && max_furniture >= min_furniture && max_furniture <= 60,
          "furniture per room must satisfy 0 <= min <= max <= 60");
  Require(min_clutter >= 0 && max_clutter >= min_clutter && max_clutter <= 60,
          "clutter per room must satisfy 0 <= min <= max <= 60");
  Require(clearance_m >= 0 && clearance_m < 1, "clearance_m must be in [0, 1)");
  Require(wall_height_m >= 2 && wall_height_m <= 10, "wall_height_m must be in [2, 10]");
  Require(frames_per_room >= 1 && frames_per_room <= 64, "frames_per_room must be in 1..64");
  Require(min_camera_height_m > 0 && max_camera_height_m >= min_camera_height_m &&
              max_camera_height_m < wall_height_m,
          "camera heights must satisfy 0 < min <= max < wall height");
  Require(min_pitch_deg >= -30 && max_pitch_deg >= min_pitch_deg && max_pitch_deg <= 80,
          "camera pitch must satisfy -30 <= min <= max <= 80 degrees");
  Require(max_clutter_side_m >= 0.3 && max_clutter_side_m <= 4,
          "max_clutter_side_m " + std::to_string(max_clutter_side_m) + " must be in [0.3, 4]");
  Require(surface_clutter >= 0 && surface_clutter <= 1,
          "surface_clutter " + std::to_string(surface_clutter) + " must be in [0, 1]");
  Require(size_jitter >= 0 && size_jitter <= 0.5,
          "size_jitter " + std::to_string(size_jitter) + " must be in [0, 0.5]");
}

ComposerCatalog ComposerCatalog::From(const Catalog& catalog, const RoomOptions& room) {
  ComposerCatalog result;
  for (const CatalogEntry& entry : catalog.entries()) {
    Item item{entry.id, entry.furniture_class, entry.size_m.cast<double>()};
    if (entry.furniture_class) {
      if ((room.include_evaluation_only || !entry.evaluation_only) &&
          (room.include_vote_net_only || !entry.vote_net_only))
        result.furniture.push_back(item);
      continue;
    }
    const Eigen::Vector3d& s = item.size_m;
    const double side = room.max_clutter_side_m;
    const bool plausible = !entry.door_or_window && s.x() >= 0.1 && s.y() >= 0.1 && s.x() <= side &&
                           s.y() <= side && s.z() >= 0.05 && s.z() <= 2.0;
    if (plausible) result.clutter.push_back(item);
  }
  return result;
}

ComposerCatalog ComposerCatalog::WithFurnitureFrom(const std::set<std::string>& ids) const {
  ComposerCatalog result;
  result.clutter = clutter;
  for (const Item& item : furniture) {
    if (ids.count(item.id)) result.furniture.push_back(item);
  }
  return result;
}

bool FootprintsOverlap(const PlacedObject& a, const PlacedObject& b, double clearance) {
  // Separating axis test on the two rectangles, each widened by half the clearance.
  const auto corners_a = FootprintCorners(a, clearance / 2),
             corners_b = FootprintCorners(b, clearance / 2);
  for (const auto* corners : {&corners_a, &corners_b}) {
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector2d edge = (*corners)[k + 1] - (*corners)[k];
      const Eigen::Vector2d axis(-edge.y(), edge.x());
      double min_a = 1e300, max_a = -1e300, min_b = 1e300, max_b = -1e300;
      for (const Eigen::Vector2d& p : corners_a) {
        min_a = std::min(min_a, axis.dot(p));
        max_a = std::max(max_a, axis.dot(p));
      }
      for (const Eigen::Vector2d& p : corners_b) {
        min_b = std::min(min_b, axis.dot(p));
        max_b = std::max(max_b, axis.dot(p));
      }
      if (max_a <= min_b || max_b <= min_a) return false;
    }
  }
  return true;
}

RoomLayout ComposeRoom(const ComposerCatalog& catalog,
                       const RoomOptions& options,
                       uint64_t room_seed) {
  options.Check();
  Require(!catalog.furniture.empty(), "the catalog has no class-mapped furniture to place");
  Rng rng(room_seed);
  RoomLayout room;
  room.seed = room_seed;
  room.width_m = rng.Uniform(options.min_side_m, options.max_side_m);
  room.depth_m = rng.Uniform(options.min_side_m, options.max_side_m);
  room.wall_height_m = options.wall_height_m;
  room.requested_furniture =
      static_cast<int>(rng.UniformInt(options.min_furniture, options.max_furniture));

  // A keep-out zone where the cameras will surely fit, however full the room.
  PlacedObject camera_zone;
  camera_zone.model_id = "(camera zone)";
  camera_zone.size_m = Eigen::Vector3d(0.9, 0.9, 0);
  camera_zone.x = rng.Uniform(-room.width_m / 2 + 0.5, room.width_m / 2 - 0.5);
  camera_zone.y = rng.Uniform(-room.depth_m / 2 + 0.5, room.depth_m / 2 - 0.5);
  room.objects.push_back(camera_zone);

  // Arrangements people make: a dining group, sideboards against walls, then
  // free-standing pieces of any class.
  const SizeJitter jitter(catalog, options.size_jitter);
  int placed = 0;
  if (rng.Bernoulli(0.75)) {
    placed += PlaceDiningGroup(
        catalog, jitter, room.requested_furniture, &room, options.clearance_m, &rng);
  }
  int attempts = 0;
  while (placed < room.requested_furniture && attempts < 3 * room.requested_furniture + 10) {
    ++attempts;
    const ComposerCatalog::Item item = jitter.Apply(
        catalog.furniture[rng.UniformInt(0, static_cast<int64_t>(catalog.furniture.size()) - 1)],
        &rng);
    const bool wall_piece =
        item.furniture_class == FurnitureClass::kSideboard || rng.Bernoulli(0.2);
    if (wall_piece ? PlaceAgainstWall(item, &room, options.clearance_m, &rng)
                   : PlaceFreeStanding(item, &room, options.clearance_m, &rng)) {
      ++placed;
    }
  }
  room.placed_furniture = placed;
  if (!catalog.clutter.empty()) {
    const int clutter = static_cast<int>(rng.UniformInt(options.min_clutter, options.max_clutter));
    for (int k = 0; k < clutter; ++k) {
      const auto& item =
          catalog.clutter[rng.UniformInt(0, static_cast<int64_t>(catalog.clutter.size()) - 1)];
      if (!(rng.Bernoulli(0.5) ? PlaceAgainstWall(item, &room, options.clearance_m, &rng)
                               : PlaceFreeStanding(item, &room, options.clearance_m, &rng))) {
        continue;
      }
    }
  }
  if (options.surface_clutter > 0) PlaceOnSurfaces(catalog, options.surface_clutter, &room, &rng);
  room.objects.erase(room.objects.begin());  // the camera zone
  uint16_t next_id = kFirstObjectId;
  for (PlacedObject& object : room.objects) object.instance_id = next_id++;

  PlaceCameras(camera_zone, options, &room, &rng);
  Require(!room.world_from_cameras.empty(),
          "room " + std::to_string(room_seed) + ": no free space for a camera");
  return room;
}

Scene BuildRoomScene(const RoomLayout& layout,
                     const std::map<std::string, std::shared_ptr<const TriangleMesh>>& meshes) {
  Scene scene;
  const float hx = static_cast<float>(layout.width_m / 2),
              hy = static_cast<float>(layout.depth_m / 2);
  const float h = static_cast<float>(layout.wall_height_m), t = static_cast<float>(kWallThickness);
  scene.objects.push_back(
      {std::make_shared<TriangleMesh>(MakeBox({-hx - t, -hy - t, -0.05f}, {hx + t, hy + t, 0})),
       Eigen::Isometry3d::Identity(),
       kFloorId});
  const TriangleMesh walls[] = {MakeBox({-hx - t, hy, 0}, {hx + t, hy + t, h}),
                                MakeBox({-hx - t, -hy - t, 0}, {hx + t, -hy, h}),
                                MakeBox({hx, -hy, 0}, {hx + t, hy, h}),
                                MakeBox({-hx - t, -hy, 0}, {-hx, hy, h})};
  for (const TriangleMesh& wall : walls) {
    scene.objects.push_back(
        {std::make_shared<TriangleMesh>(wall), Eigen::Isometry3d::Identity(), kWallId});
  }
  for (const PlacedObject& object : layout.objects) {
    const auto it = meshes.find(object.model_id);
    Require(it != meshes.end(), "no mesh loaded for model " + object.model_id);
    std::shared_ptr<const TriangleMesh> mesh = it->second;
    if (object.scale != Eigen::Vector3d::Ones()) {  // size jitter: a resized copy
      auto resized = std::make_shared<TriangleMesh>(*mesh);
      TransformMesh(object.scale.cast<float>().asDiagonal().toDenseMatrix(),
                    Eigen::Vector3f::Zero(),
                    resized.get());
      mesh = std::move(resized);
    }
    scene.objects.push_back({mesh, object.WorldFromObject(), object.instance_id});
  }
  return scene;
}

}  // namespace furn
