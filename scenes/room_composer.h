// Composes furnished rooms from a catalog (SPEC.md §5): a rectangular room,
// furniture of the class map in arrangements people make (chairs around a
// table, sideboards against walls, free-standing pieces), clutter from
// entries outside the class map, all upright with footprints that do not
// overlap (oriented rectangles with clearance), and Kinect camera poses in free
// space looking into the room. A pure function of the room seed.
//
//   RoomLayout layout = ComposeRoom(ComposerCatalog::From(catalog), RoomOptions{}, room_seed);
//   Scene scene = BuildRoomScene(layout, meshes_by_model_id);
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/geometry/mesh.h"
#include "core/geometry/scene.h"
#include "core/model/furniture_class.h"

namespace furn {

class Catalog;

struct RoomOptions {
  double min_side_m = 3.0;  // room width and depth drawn in [min, max] (m)
  double max_side_m = 8.0;
  int min_furniture = 4;  // class-mapped pieces per room, drawn in [min, max]
  int max_furniture = 9;
  int min_clutter = 1;  // pieces from outside the class map
  int max_clutter = 4;
  // The clutter entries' longest footprint side (m): 1.6 keeps beds, long
  // shelves and kitchen runs out; real rooms have them beside the furniture
  // (issue 69).
  double max_clutter_side_m = 1.6;
  // The share of tables and sideboards that carry one to three small clutter
  // pieces on their top (footprint sides and height up to 0.5 m: lamps,
  // plants, boxes), as real ones do (issue 69); 0: none, and no random draws,
  // so rooms made before the option stay the same.
  double surface_clutter = 0;
  double clearance_m = 0.05;   // free gap between footprints (m)
  double wall_height_m = 2.6;  // (m)
  int frames_per_room = 4;     // camera poses per room (1..64)
  double min_camera_height_m = 0.6;
  double max_camera_height_m = 1.6;
  double min_pitch_deg = 0.0;  // camera pitch down (degrees)
  double max_pitch_deg = 35.0;
  bool include_evaluation_only = true;  // evaluation-only entries may appear in rooms
  bool include_vote_net_only = false;   // so may vote-net-only ones (its training rooms)
  // Per-object anisotropic size jitter of the class-mapped pieces: each side is
  // scaled by a factor drawn in [1 - j, 1 + j], then kept within the range of
  // that class's sizes in the catalog (a vote network's training rooms; 0: the
  // CAD models' own sizes, and no random draws, so older datasets stay the same).
  double size_jitter = 0.0;

  // Throws InputError naming the field and the rule.
  void Check() const;
};

// What the composer needs from a catalog: ids, classes and sizes.
struct ComposerCatalog {
  struct Item {
    std::string id;
    std::optional<FurnitureClass> furniture_class;     // none: clutter
    Eigen::Vector3d size_m = Eigen::Vector3d::Zero();  // width (x), depth (y), height (z)
    Eigen::Vector3d scale = Eigen::Vector3d::Ones();   // of the model's mesh, per axis
  };
  std::vector<Item> furniture;  // class-mapped
  std::vector<Item> clutter;    // plausible distractors outside the class map

  // Clutter: not a door or window, footprint sides 0.1 m .. the room options'
  // max_clutter_side_m, 0.05..2.0 m tall.
  // The room options' include_* flags decide which class-mapped entries are
  // furniture (evaluation-only: yes by default; vote-net-only: no).
  static ComposerCatalog From(const Catalog& catalog, const RoomOptions& room = RoomOptions{});
  // The same clutter, and only the class-mapped entries whose id is in `ids`.
  ComposerCatalog WithFurnitureFrom(const std::set<std::string>& ids) const;
};

struct PlacedObject {
  std::string model_id;
  std::optional<FurnitureClass> furniture_class;  // set for detection targets
  uint16_t instance_id = 0;
  double x = 0, y = 0, yaw = 0;  // pose of the model frame (base on the floor, z = 0) ...
  double z = 0;                  // ... or on the top of another piece (surface clutter)
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // of the model's mesh (size jitter)

  bool IsTarget() const { return furniture_class.has_value(); }
  Eigen::Isometry3d WorldFromObject() const { return PoseXYZYaw(x, y, z, yaw); }
};

struct RoomLayout {
  uint64_t seed = 0;
  double width_m = 0;  // along x, room spans [-width/2, width/2]
  double depth_m = 0;  // along y
  double wall_height_m = 0;
  std::vector<PlacedObject> objects;
  std::vector<Eigen::Isometry3d> world_from_cameras;
  int requested_furniture = 0;  // how many pieces the room asked for
  int placed_furniture = 0;     // how many fitted
};

// Throws InputError when the catalog has no furniture or the options are bad.
RoomLayout ComposeRoom(const ComposerCatalog& catalog,
                       const RoomOptions& options,
                       uint64_t room_seed);

// Floor (kFloorId), four walls (kWallId) and every placed object, with meshes
// from `meshes` (by model id; throws InputError for a missing one).
Scene BuildRoomScene(const RoomLayout& layout,
                     const std::map<std::string, std::shared_ptr<const TriangleMesh>>& meshes);

// True when the two footprints (oriented rectangles, widened by `clearance`
// on every side) overlap.
bool FootprintsOverlap(const PlacedObject& a, const PlacedObject& b, double clearance);

}  // namespace furn
