// A labelled synthetic dataset in one SQLite file (SPEC.md §6).
//
// Tables: meta (schema version), generation (the options a dataset was made
// with), models, rooms (seed, split, size), objects (pose, class, footprint per
// room), frames (intrinsics, world_from_camera, ideal and noisy depth and id
// images as 16-bit PNG BLOBs, a content hash), frame_objects (visible and
// amodal pixels, visibility, boxes, in-frustum flag). A room and everything in
// it is written in one transaction, so a killed run leaves only whole rooms.
// Images live in the database (not beside it) so a dataset is one file to copy,
// shard and merge.
//
//   DatasetDb dataset("synth.db", DatasetDb::Mode::kReadWrite);
//   if (!dataset.HasRoom(7)) dataset.WriteRoom(room_record);
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/model/furniture_box.h"
#include "db/split.h"
#include "db/sqlite.h"

namespace furn {

inline constexpr int kDatasetSchemaVersion = 2;  // 2: evaluation runs

struct ModelRecord {
  std::string id;
  std::optional<FurnitureClass> furniture_class;  // none: clutter
  std::string content_hash;
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();
  bool evaluation_only = false;
};

struct ObjectRecord {
  int instance_id = 0;
  std::string model_id;
  std::optional<FurnitureClass> furniture_class;  // none: clutter, not a detection target
  double x = 0, y = 0, z = 0, yaw = 0;            // world_from_object
  double reference_x = 0, reference_y = 0;        // footprint centre on the floor (SPEC §3)
  double width = 0, depth = 0, height = 0;        // m

  // The piece's box: the reference point, yaw and footprint.
  FurnitureBox Footprint() const { return {reference_x, reference_y, yaw, width, depth}; }
};

struct FrameObjectRecord {
  int instance_id = 0;
  int64_t visible_pixels = 0;                       // pixels of the ideal id image showing it
  int64_t amodal_pixels = 0;                        // pixels it covers when rendered alone
  double visibility = 0;                            // visible / amodal (0 when amodal is 0)
  std::array<int, 4> visible_box = {0, 0, -1, -1};  // u0, v0, u1, v1 inclusive; empty if u1 < u0
  std::array<int, 4> amodal_box = {0, 0, -1, -1};
  bool in_frustum = false;  // some of it projects into the image
};

struct FrameRecord {
  int64_t id = 0;  // room_id * frames_per_room + frame_index: stable across shards
  int frame_index = 0;
  uint64_t seed = 0;
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  std::vector<uint8_t> depth_ideal_png, depth_noisy_png, ids_png, ids_noisy_png;
  std::string content_hash;
  std::vector<FrameObjectRecord> objects;
};

struct RoomRecord {
  int64_t id = 0;
  uint64_t seed = 0;
  Split split = Split::kTrain;  // train, val or test
  double width = 0, depth = 0;
  int requested_furniture = 0, placed_furniture = 0;
  std::vector<ObjectRecord> objects;
  std::vector<FrameRecord> frames;
};

// One evaluation run (or tuning trial): where its numbers came from.
struct RunRecord {
  int64_t id = 0;
  std::string kind = "evaluate";  // evaluate, tune, ...
  std::string label;
  std::string started;  // UTC, ISO 8601
  std::string git_commit;
  bool git_dirty = false;
  std::string model_path, model_hash, dataset_hash;
  Split split = Split::kAll;  // the frames evaluated
  std::string options_json;   // every option used
  std::string results_json;   // PR curves and confusion, for reports
};

struct RunDetectionRecord {
  int64_t frame_id = 0;
  FurnitureClass furniture_class = FurnitureClass::kChair;
  std::string model_id;
  double x = 0, y = 0, z = 0, yaw = 0;
  double score = 0, vote_weight = 0, verification = 0, covered_fraction = 0;
};

struct RunFrameRecord {
  int64_t frame_id = 0;
  double total_ms = 0;
  std::string timings_json;  // stage -> ms
};

class DatasetDb {
 public:
  using Mode = OpenMode;
  // kReadWrite creates the file and schema when missing; kReadWriteExisting
  // (adding runs to a dataset) and kReadOnly throw DbError for a missing file
  // and create nothing. Throws DbError for a file that is not SQLite, or a
  // schema newer than this build or unknown.
  DatasetDb(const std::string& path, Mode mode);

  const std::string& path() const { return db_.path(); }
  Database* database() { return &db_; }

  // The options JSON a dataset was generated with (none for a new file).
  std::optional<std::string> GenerationOptions();
  void SetGenerationOptions(const std::string& options_json);

  // Inserts models not yet present; throws DbError when an id is present with
  // another content hash (the catalog changed under the dataset).
  void WriteModels(const std::vector<ModelRecord>& models);
  std::vector<ModelRecord> ReadModels();

  bool HasRoom(int64_t room_id);
  // The room, its objects and frames, in one transaction. `before_commit`
  // runs inside it, after every row is written (tests use it to crash there).
  void WriteRoom(const RoomRecord& room, const std::function<void()>& before_commit = {});
  std::vector<int64_t> RoomIds();
  // Runs (schema 2). WriteRun stores one run in one transaction and returns
  // its id; Runs lists them by id (none for an older, read-only dataset).
  bool HasRuns();
  int64_t WriteRun(const RunRecord& run,
                   const std::map<std::string, double>& metrics,
                   const std::vector<RunDetectionRecord>& detections,
                   const std::vector<RunFrameRecord>& frames);
  std::vector<RunRecord> Runs();
  std::map<std::string, double> RunMetrics(int64_t run_id);
  std::vector<RunFrameRecord> RunFrames(int64_t run_id);

  // The room holding a frame, or nothing when no frame has that id.
  std::optional<int64_t> RoomOfFrame(int64_t frame_id);
  RoomRecord ReadRoom(int64_t room_id, bool with_images);

 private:
  void CreateOrMigrate(Mode mode);
  Database db_;
};

// Removes a database file and its -wal and -shm files, those that exist.
void RemoveDatabaseFiles(const std::string& path);

// Train, val or test for a room seed, by fixed ratios 0.6 / 0.2 / 0.2.
Split SplitForSeed(uint64_t room_seed);

}  // namespace furn
