// `workbench generate`: labelled synthetic Kinect frames from a catalog, into
// a dataset database (db/dataset_db.h).
//
// Room k of a run has seed DeriveSeed(seed, k) and frame j of it
// DeriveSeed(room_seed, j + 1), so a room is the same whether generated alone,
// in a batch or in a shard. Rooms already in the database are skipped, which
// makes an interrupted run resumable by running it again.
//
//   GenerateOptions options;
//   options.rooms = 50;
//   GenerateSummary summary = GenerateDataset(catalog, options, "synth.db");
#pragma once

#include <cstdint>
#include <set>
#include <string>

#include "db/dataset_db.h"
#include "renderers/camera.h"
#include "renderers/depth_renderer.h"
#include "renderers/kinect_noise.h"
#include "scenes/catalog.h"
#include "scenes/model_folds.h"
#include "scenes/room_composer.h"

namespace furn {

class EmbreeCaster;

struct GenerateOptions {
  std::string catalog_spec = "default";  // recorded in the database
  // Catalogs whose unclassified entries were added as clutter
  // (Catalog::AddClutter); recorded in the database.
  std::vector<std::string> clutter_catalog_specs;
  int rooms = 50;       // rooms of the whole run, all shards (1..1000000)
  uint64_t seed = 1;    // master seed
  int shard_index = 0;  // this process makes rooms k with k % shard_count == shard_index
  int shard_count = 1;
  RoomOptions room;
  KinectNoiseOptions noise;
  RendererKind renderer = RendererKind::kEmbree;
  CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  // Leave-models-out rooms (protocol E, scenes/model_folds.h): with K >= 2 the
  // class-mapped models are split into K folds by AssignModelFolds(catalog, K,
  // fold_seed) and room k's targets come from fold k % K only (clutter as
  // usual). 0: every class-mapped model may appear in every room.
  int model_folds = 0;
  uint64_t fold_seed = 1;
  // Class-mapped models never placed (the held-out models of a fold when a
  // vote network's training rooms are made); empty: none.
  std::set<std::string> excluded_models;

  // Throws InputError naming the field and the rule.
  void Check() const;
  // Everything that decides the content, as JSON (shard excluded, so shards
  // of one run can be merged).
  std::string ContentJson() const;
};

struct GenerateSummary {
  int rooms_in_shard = 0;
  int rooms_written = 0;
  int rooms_already_present = 0;
  int frames_written = 0;
  int rooms_short = 0;  // rooms where fewer pieces fitted than were asked for
  double seconds = 0;
  int workers = 1;  // rooms rendered at once, one per thread
  // Seconds spent per stage, summed over rooms: thread-seconds for the stages
  // the workers run (scene set-up in load, render, ground truth, PNG), wall
  // seconds for the rest (compose, model import on all cores, database).
  double compose_s = 0, load_s = 0, render_s = 0, ground_truth_s = 0, encode_s = 0, insert_s = 0;
};

GenerateSummary GenerateDataset(const Catalog& catalog,
                                const GenerateOptions& options,
                                const std::string& db_path);

// Ground truth of every placed object in one view of a room: visible pixels
// and box (from the ideal id image), amodal pixels and box (the object ray cast
// alone over its projected bounding box), visibility = visible / amodal, and
// whether any of it is in view. Keeps one ray-casting scene per object, so
// construct it once per room and call it per frame.
class ObjectGroundTruth {
 public:
  // `scene` is BuildRoomScene(layout, ...): structure first, then the objects.
  ObjectGroundTruth(const RoomLayout& layout, const Scene& scene);
  ~ObjectGroundTruth();
  std::vector<FrameObjectRecord> Compute(const DepthFrame& ideal,
                                         const CameraIntrinsics& camera,
                                         const Eigen::Isometry3d& world_from_camera);

 private:
  const RoomLayout& layout_;
  std::vector<Scene> alone_;
  std::vector<std::unique_ptr<EmbreeCaster>> casters_;
};

// "i/N" -> (i, N); throws InputError unless 0 <= i < N.
std::pair<int, int> ParseShard(const std::string& text);

// The catalog rooms are composed from: `spec`, with every catalog of
// `clutter_specs` adding its unclassified entries as clutter (InputError for
// one that adds none); the catalog's warnings, and a warning when rooms ask
// for clutter it cannot offer, on stderr.
Catalog OpenGenerationCatalog(const std::string& spec,
                              const std::vector<std::string>& clutter_specs,
                              const CatalogOpenOptions& open_options,
                              const RoomOptions& room,
                              bool quiet);

}  // namespace furn
