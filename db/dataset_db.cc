#include "db/dataset_db.h"

#include <filesystem>
#include <sstream>

namespace furn {
namespace {

// A class column: the class name, or empty for clutter.
std::string ClassText(const std::optional<FurnitureClass>& furniture_class) {
  return furniture_class ? ClassName(*furniture_class) : "";
}

std::optional<FurnitureClass> ClassOfColumn(const std::string& text, const std::string& db_path) {
  if (text.empty()) return std::nullopt;
  const std::optional<FurnitureClass> furniture_class = FurnitureClassNamed(text);
  if (!furniture_class) {
    throw DbError(db_path + ": unknown class '" + text +
                  "' (allowed: " + EnumNameList<FurnitureClass>() + "; a damaged or newer file)");
  }
  return furniture_class;
}

constexpr char kSchemaV1[] = R"(
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE generation (
  id INTEGER PRIMARY KEY CHECK (id = 1),
  options_json TEXT NOT NULL);
CREATE TABLE models (
  id TEXT PRIMARY KEY,
  class TEXT NOT NULL,
  content_hash TEXT NOT NULL,
  width REAL NOT NULL, depth REAL NOT NULL, height REAL NOT NULL,
  evaluation_only INTEGER NOT NULL);
CREATE TABLE rooms (
  id INTEGER PRIMARY KEY,
  seed INTEGER NOT NULL,
  split TEXT NOT NULL CHECK (split IN ('train', 'val', 'test')),
  width REAL NOT NULL, depth REAL NOT NULL,
  requested_furniture INTEGER NOT NULL, placed_furniture INTEGER NOT NULL);
CREATE TABLE objects (
  room_id INTEGER NOT NULL REFERENCES rooms(id) ON DELETE CASCADE,
  instance_id INTEGER NOT NULL,
  model_id TEXT NOT NULL REFERENCES models(id),
  class TEXT NOT NULL,
  x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL, yaw REAL NOT NULL,
  reference_x REAL NOT NULL, reference_y REAL NOT NULL,
  width REAL NOT NULL, depth REAL NOT NULL, height REAL NOT NULL,
  PRIMARY KEY (room_id, instance_id));
CREATE TABLE frames (
  id INTEGER PRIMARY KEY,
  room_id INTEGER NOT NULL REFERENCES rooms(id) ON DELETE CASCADE,
  frame_index INTEGER NOT NULL,
  seed INTEGER NOT NULL,
  width INTEGER NOT NULL, height INTEGER NOT NULL,
  fx REAL NOT NULL, fy REAL NOT NULL, cx REAL NOT NULL, cy REAL NOT NULL,
  world_from_camera TEXT NOT NULL,
  depth_ideal_png BLOB NOT NULL, depth_noisy_png BLOB NOT NULL,
  ids_png BLOB NOT NULL, ids_noisy_png BLOB NOT NULL,
  content_hash TEXT NOT NULL,
  UNIQUE (room_id, frame_index));
CREATE TABLE frame_objects (
  frame_id INTEGER NOT NULL REFERENCES frames(id) ON DELETE CASCADE,
  instance_id INTEGER NOT NULL,
  visible_pixels INTEGER NOT NULL, amodal_pixels INTEGER NOT NULL, visibility REAL NOT NULL,
  visible_u0 INTEGER NOT NULL, visible_v0 INTEGER NOT NULL, visible_u1 INTEGER NOT NULL, visible_v1 INTEGER NOT NULL,
  amodal_u0 INTEGER NOT NULL, amodal_v0 INTEGER NOT NULL, amodal_u1 INTEGER NOT NULL, amodal_v1 INTEGER NOT NULL,
  in_frustum INTEGER NOT NULL,
  PRIMARY KEY (frame_id, instance_id));
CREATE INDEX frames_by_room ON frames(room_id);
)";

// Version 2: evaluation runs (SPEC.md §6, §10), one row per `evaluate` or
// tuning trial, its metrics, detections and per-frame timings.
constexpr char kSchemaV2[] = R"(
CREATE TABLE runs (
  id INTEGER PRIMARY KEY,
  kind TEXT NOT NULL,
  label TEXT NOT NULL,
  started TEXT NOT NULL,
  git_commit TEXT NOT NULL,
  git_dirty INTEGER NOT NULL,
  model_path TEXT NOT NULL,
  model_hash TEXT NOT NULL,
  dataset_hash TEXT NOT NULL,
  split TEXT NOT NULL,
  options_json TEXT NOT NULL,
  results_json TEXT NOT NULL);
CREATE TABLE run_metrics (
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  name TEXT NOT NULL,
  value REAL NOT NULL,
  PRIMARY KEY (run_id, name));
CREATE TABLE run_detections (
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  frame_id INTEGER NOT NULL,
  class TEXT NOT NULL,
  x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL, yaw REAL NOT NULL,
  model_id TEXT NOT NULL,
  score REAL NOT NULL, vote_weight REAL NOT NULL, verification REAL NOT NULL,
  covered_fraction REAL NOT NULL);
CREATE INDEX run_detections_by_run ON run_detections(run_id, frame_id);
CREATE TABLE run_frames (
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  frame_id INTEGER NOT NULL,
  total_ms REAL NOT NULL,
  timings_json TEXT NOT NULL,
  PRIMARY KEY (run_id, frame_id));
)";

int64_t AsSigned(uint64_t value) { return static_cast<int64_t>(value); }
uint64_t AsUnsigned(int64_t value) { return static_cast<uint64_t>(value); }

std::string PoseText(const Eigen::Isometry3d& pose) {
  std::ostringstream text;
  text.precision(17);
  const Eigen::Matrix4d m = pose.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) text << (r || c ? " " : "") << m(r, c);
  }
  return text.str();
}

Eigen::Isometry3d ParsePose(const std::string& text, const std::string& where) {
  std::istringstream stream(text);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (!(stream >> m(r, c))) throw DbError(where + ": world_from_camera is not 16 numbers");
    }
  }
  Eigen::Isometry3d pose;
  pose.matrix() = m;
  return pose;
}

}  // namespace

Split SplitForSeed(uint64_t room_seed) {
  // The top bits of a mixed seed, so neighbouring seeds spread over the splits.
  const uint64_t mixed = (room_seed ^ (room_seed >> 31)) * 0x9E3779B97F4A7C15ull;
  const uint64_t bucket = (mixed >> 40) % 10;
  return bucket < 6 ? Split::kTrain : bucket < 8 ? Split::kVal : Split::kTest;
}

namespace {

// The database mode of a dataset mode; first checks that a dataset that must
// exist does (SQLite's own "unable to open database file" names no cause).
OpenMode CheckedOpenMode(const std::string& path, OpenMode mode) {
  if (mode == OpenMode::kReadWrite) return mode;
  std::error_code error;
  if (!std::filesystem::exists(path, error))
    throw DbError(path + ": no such dataset file (make one with 'workbench generate')");
  return mode;
}

}  // namespace

DatasetDb::DatasetDb(const std::string& path, Mode mode) : db_(path, CheckedOpenMode(path, mode)) {
  CreateOrMigrate(mode);
}

void DatasetDb::CreateOrMigrate(Mode mode) {
  int64_t table_count = 0;
  try {
    Statement tables(&db_, "SELECT count(*) FROM sqlite_master WHERE type = 'table'");
    tables.Step();
    table_count = tables.ColumnInt(0);
  } catch (const DbError& error) {
    // A cause the user can act on (read-only, full disk, another writer)
    // passes as it is; otherwise SQLite's reason comes last in the message
    // ("file is not a database", ...).
    const std::string message = error.what();
    if (message.find("cannot write") != std::string::npos ||
        message.find("another process") != std::string::npos ||
        message.find("input/output") != std::string::npos)
      throw;
    throw DbError(db_.path() + ": not a furnidet dataset (" +
                  message.substr(message.rfind(": ") + 2) + ")");
  }
  const bool empty = table_count == 0;
  if (empty) {
    if (mode != Mode::kReadWrite) throw DbError(db_.path() + ": not a dataset (no tables)");
    Transaction transaction(&db_);
    db_.Execute(kSchemaV1);
    db_.Execute(kSchemaV2);
    Statement version(
        &db_,
        "INSERT INTO meta(key, value) VALUES ('schema_version', ?), ('kind', 'furnidet-dataset')");
    version.Bind(1, std::to_string(kDatasetSchemaVersion)).Run();
    transaction.Commit();
    return;
  }
  Statement kind(&db_, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'meta'");
  kind.Step();
  if (kind.ColumnInt(0) == 0)
    throw DbError(db_.path() + ": not a furnidet dataset (no meta table)");
  Statement version(&db_, "SELECT value FROM meta WHERE key = 'schema_version'");
  if (!version.Step()) throw DbError(db_.path() + ": not a furnidet dataset (no schema version)");
  const int found = std::stoi(version.ColumnText(0));
  if (found > kDatasetSchemaVersion) {
    throw DbError(db_.path() + ": dataset schema version " + std::to_string(found) +
                  " is newer than this build reads (" + std::to_string(kDatasetSchemaVersion) +
                  "); update furnidet");
  }
  if (found < 1)
    throw DbError(db_.path() + ": unknown dataset schema version " + std::to_string(found));
  // Migrations, one transaction per step; a read-only open reads older
  // versions as they are (they have no runs).
  if (found < 2 && mode != Mode::kReadOnly) {
    Transaction transaction(&db_);
    db_.Execute(kSchemaV2);
    db_.Execute("UPDATE meta SET value = '2' WHERE key = 'schema_version'");
    transaction.Commit();
  }
}

bool DatasetDb::HasRuns() {
  Statement query(&db_,
                  "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'runs'");
  query.Step();
  return query.ColumnInt(0) > 0;
}

int64_t DatasetDb::WriteRun(const RunRecord& run,
                            const std::map<std::string, double>& metrics,
                            const std::vector<RunDetectionRecord>& detections,
                            const std::vector<RunFrameRecord>& frames) {
  Transaction transaction(&db_);
  Statement insert(&db_,
                   "INSERT INTO runs(kind, label, started, git_commit, git_dirty, model_path, "
                   "model_hash, dataset_hash, split, options_json, results_json) "
                   "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  insert.Bind(1, run.kind)
      .Bind(2, run.label)
      .Bind(3, run.started)
      .Bind(4, run.git_commit)
      .Bind(5, int64_t{run.git_dirty})
      .Bind(6, run.model_path)
      .Bind(7, run.model_hash)
      .Bind(8, run.dataset_hash)
      .Bind(9, std::string(EnumName(run.split)))
      .Bind(10, run.options_json)
      .Bind(11, run.results_json)
      .Run();
  const int64_t id = db_.LastInsertRowId();
  Statement metric(&db_, "INSERT INTO run_metrics(run_id, name, value) VALUES (?, ?, ?)");
  for (const auto& [name, value] : metrics) {
    metric.Reset();
    metric.Bind(1, id).Bind(2, name).Bind(3, value).Run();
  }
  Statement detection(&db_,
                      "INSERT INTO run_detections(run_id, frame_id, class, x, y, z, yaw, model_id, "
                      "score, vote_weight, verification, covered_fraction) "
                      "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  for (const RunDetectionRecord& d : detections) {
    detection.Reset();
    detection.Bind(1, id)
        .Bind(2, d.frame_id)
        .Bind(3, std::string(ClassName(d.furniture_class)))
        .Bind(4, d.x)
        .Bind(5, d.y)
        .Bind(6, d.z)
        .Bind(7, d.yaw)
        .Bind(8, d.model_id)
        .Bind(9, d.score)
        .Bind(10, d.vote_weight)
        .Bind(11, d.verification)
        .Bind(12, d.covered_fraction)
        .Run();
  }
  Statement frame(
      &db_, "INSERT INTO run_frames(run_id, frame_id, total_ms, timings_json) VALUES (?, ?, ?, ?)");
  for (const RunFrameRecord& f : frames) {
    frame.Reset();
    frame.Bind(1, id).Bind(2, f.frame_id).Bind(3, f.total_ms).Bind(4, f.timings_json).Run();
  }
  transaction.Commit();
  return id;
}

std::vector<RunRecord> DatasetDb::Runs() {
  std::vector<RunRecord> runs;
  if (!HasRuns()) return runs;
  Statement query(&db_,
                  "SELECT id, kind, label, started, git_commit, git_dirty, model_path, model_hash, "
                  "dataset_hash, split, options_json, results_json FROM runs ORDER BY id");
  while (query.Step()) {
    RunRecord run;
    run.id = query.ColumnInt(0);
    run.kind = query.ColumnText(1);
    run.label = query.ColumnText(2);
    run.started = query.ColumnText(3);
    run.git_commit = query.ColumnText(4);
    run.git_dirty = query.ColumnInt(5) != 0;
    run.model_path = query.ColumnText(6);
    run.model_hash = query.ColumnText(7);
    run.dataset_hash = query.ColumnText(8);
    run.split = ParseSplit(query.ColumnText(9), db_.path() + ": run split");
    run.options_json = query.ColumnText(10);
    run.results_json = query.ColumnText(11);
    runs.push_back(std::move(run));
  }
  return runs;
}

std::vector<RunFrameRecord> DatasetDb::RunFrames(int64_t run_id) {
  std::vector<RunFrameRecord> frames;
  if (!HasRuns()) return frames;
  Statement query(
      &db_,
      "SELECT frame_id, total_ms, timings_json FROM run_frames WHERE run_id = ? ORDER BY frame_id");
  query.Bind(1, run_id);
  while (query.Step())
    frames.push_back({query.ColumnInt(0), query.ColumnDouble(1), query.ColumnText(2)});
  return frames;
}

std::map<std::string, double> DatasetDb::RunMetrics(int64_t run_id) {
  std::map<std::string, double> metrics;
  if (!HasRuns()) return metrics;
  Statement query(&db_, "SELECT name, value FROM run_metrics WHERE run_id = ? ORDER BY name");
  query.Bind(1, run_id);
  while (query.Step()) metrics[query.ColumnText(0)] = query.ColumnDouble(1);
  return metrics;
}

std::optional<std::string> DatasetDb::GenerationOptions() {
  Statement query(&db_, "SELECT options_json FROM generation WHERE id = 1");
  if (!query.Step()) return std::nullopt;
  return query.ColumnText(0);
}

void DatasetDb::SetGenerationOptions(const std::string& options_json) {
  Statement insert(&db_, "INSERT INTO generation(id, options_json) VALUES (1, ?)");
  insert.Bind(1, options_json).Run();
}

void DatasetDb::WriteModels(const std::vector<ModelRecord>& models) {
  Transaction transaction(&db_);
  Statement find(&db_, "SELECT content_hash FROM models WHERE id = ?");
  Statement insert(
      &db_,
      "INSERT INTO models(id, class, content_hash, width, depth, height, evaluation_only) "
      "VALUES (?, ?, ?, ?, ?, ?, ?)");
  for (const ModelRecord& model : models) {
    find.Bind(1, model.id);
    if (find.Step()) {
      const std::string hash = find.ColumnText(0);
      find.Reset();
      if (hash != model.content_hash) {
        throw DbError(db_.path() + ": model " + model.id + " has content hash " + hash +
                      " in the dataset but " + model.content_hash + " in the catalog");
      }
      continue;
    }
    find.Reset();
    insert.Bind(1, model.id)
        .Bind(2, ClassText(model.furniture_class))
        .Bind(3, model.content_hash)
        .Bind(4, model.size_m.x())
        .Bind(5, model.size_m.y())
        .Bind(6, model.size_m.z())
        .Bind(7, int64_t{model.evaluation_only})
        .Run();
  }
  transaction.Commit();
}

std::vector<ModelRecord> DatasetDb::ReadModels() {
  std::vector<ModelRecord> models;
  Statement query(&db_,
                  "SELECT id, class, content_hash, width, depth, height, evaluation_only FROM "
                  "models ORDER BY id");
  while (query.Step()) {
    ModelRecord model;
    model.id = query.ColumnText(0);
    model.furniture_class = ClassOfColumn(query.ColumnText(1), db_.path());
    model.content_hash = query.ColumnText(2);
    model.size_m =
        Eigen::Vector3d(query.ColumnDouble(3), query.ColumnDouble(4), query.ColumnDouble(5));
    model.evaluation_only = query.ColumnInt(6) != 0;
    models.push_back(model);
  }
  return models;
}

bool DatasetDb::HasRoom(int64_t room_id) {
  Statement query(&db_, "SELECT 1 FROM rooms WHERE id = ?");
  query.Bind(1, room_id);
  return query.Step();
}

std::vector<int64_t> DatasetDb::RoomIds() {
  std::vector<int64_t> ids;
  Statement query(&db_, "SELECT id FROM rooms ORDER BY id");
  while (query.Step()) ids.push_back(query.ColumnInt(0));
  return ids;
}

std::optional<int64_t> DatasetDb::RoomOfFrame(int64_t frame_id) {
  Statement query(&db_, "SELECT room_id FROM frames WHERE id = ?");
  query.Bind(1, frame_id);
  if (!query.Step()) return std::nullopt;
  return query.ColumnInt(0);
}

void DatasetDb::WriteRoom(const RoomRecord& room, const std::function<void()>& before_commit) {
  Transaction transaction(&db_);
  Statement insert_room(
      &db_,
      "INSERT INTO rooms(id, seed, split, width, depth, requested_furniture, placed_furniture) "
      "VALUES (?, ?, ?, ?, ?, ?, ?)");
  insert_room.Bind(1, room.id)
      .Bind(2, AsSigned(room.seed))
      .Bind(3, std::string(EnumName(room.split)))
      .Bind(4, room.width)
      .Bind(5, room.depth)
      .Bind(6, int64_t{room.requested_furniture})
      .Bind(7, int64_t{room.placed_furniture})
      .Run();
  Statement insert_object(
      &db_,
      "INSERT INTO objects(room_id, instance_id, model_id, class, x, y, z, yaw, reference_x, "
      "reference_y, width, depth, height) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  for (const ObjectRecord& object : room.objects) {
    insert_object.Bind(1, room.id)
        .Bind(2, int64_t{object.instance_id})
        .Bind(3, object.model_id)
        .Bind(4, ClassText(object.furniture_class))
        .Bind(5, object.x)
        .Bind(6, object.y)
        .Bind(7, object.z)
        .Bind(8, object.yaw)
        .Bind(9, object.reference_x)
        .Bind(10, object.reference_y)
        .Bind(11, object.width)
        .Bind(12, object.depth)
        .Bind(13, object.height)
        .Run();
  }
  Statement insert_frame(
      &db_,
      "INSERT INTO frames(id, room_id, frame_index, seed, width, height, fx, fy, cx, cy, "
      "world_from_camera, depth_ideal_png, depth_noisy_png, ids_png, ids_noisy_png, content_hash) "
      "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  Statement insert_frame_object(
      &db_,
      "INSERT INTO frame_objects(frame_id, instance_id, visible_pixels, amodal_pixels, "
      "visibility, visible_u0, visible_v0, visible_u1, visible_v1, amodal_u0, amodal_v0, "
      "amodal_u1, amodal_v1, in_frustum) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  for (const FrameRecord& frame : room.frames) {
    insert_frame.Bind(1, frame.id)
        .Bind(2, room.id)
        .Bind(3, int64_t{frame.frame_index})
        .Bind(4, AsSigned(frame.seed))
        .Bind(5, int64_t{frame.width})
        .Bind(6, int64_t{frame.height})
        .Bind(7, frame.fx)
        .Bind(8, frame.fy)
        .Bind(9, frame.cx)
        .Bind(10, frame.cy)
        .Bind(11, PoseText(frame.world_from_camera))
        .BindBlob(12, frame.depth_ideal_png)
        .BindBlob(13, frame.depth_noisy_png)
        .BindBlob(14, frame.ids_png)
        .BindBlob(15, frame.ids_noisy_png)
        .Bind(16, frame.content_hash)
        .Run();
    for (const FrameObjectRecord& object : frame.objects) {
      insert_frame_object.Bind(1, frame.id)
          .Bind(2, int64_t{object.instance_id})
          .Bind(3, object.visible_pixels)
          .Bind(4, object.amodal_pixels)
          .Bind(5, object.visibility);
      for (int k = 0; k < 4; ++k) insert_frame_object.Bind(6 + k, int64_t{object.visible_box[k]});
      for (int k = 0; k < 4; ++k) insert_frame_object.Bind(10 + k, int64_t{object.amodal_box[k]});
      insert_frame_object.Bind(14, int64_t{object.in_frustum}).Run();
    }
  }
  if (before_commit) before_commit();
  transaction.Commit();
}

RoomRecord DatasetDb::ReadRoom(int64_t room_id, bool with_images) {
  RoomRecord room;
  Statement query_room(&db_,
                       "SELECT seed, split, width, depth, requested_furniture, placed_furniture "
                       "FROM rooms WHERE id = ?");
  query_room.Bind(1, room_id);
  if (!query_room.Step()) throw DbError(db_.path() + ": no room " + std::to_string(room_id));
  room.id = room_id;
  room.seed = AsUnsigned(query_room.ColumnInt(0));
  room.split = ParseSplit(query_room.ColumnText(1), db_.path() + ": room split", false);
  room.width = query_room.ColumnDouble(2);
  room.depth = query_room.ColumnDouble(3);
  room.requested_furniture = static_cast<int>(query_room.ColumnInt(4));
  room.placed_furniture = static_cast<int>(query_room.ColumnInt(5));
  Statement query_objects(
      &db_,
      "SELECT instance_id, model_id, class, x, y, z, yaw, reference_x, reference_y, width, depth, "
      "height FROM objects WHERE room_id = ? ORDER BY instance_id");
  query_objects.Bind(1, room_id);
  while (query_objects.Step()) {
    ObjectRecord object;
    object.instance_id = static_cast<int>(query_objects.ColumnInt(0));
    object.model_id = query_objects.ColumnText(1);
    object.furniture_class = ClassOfColumn(query_objects.ColumnText(2), db_.path());
    object.x = query_objects.ColumnDouble(3);
    object.y = query_objects.ColumnDouble(4);
    object.z = query_objects.ColumnDouble(5);
    object.yaw = query_objects.ColumnDouble(6);
    object.reference_x = query_objects.ColumnDouble(7);
    object.reference_y = query_objects.ColumnDouble(8);
    object.width = query_objects.ColumnDouble(9);
    object.depth = query_objects.ColumnDouble(10);
    object.height = query_objects.ColumnDouble(11);
    room.objects.push_back(object);
  }
  const std::string images = with_images
                                 ? "depth_ideal_png, depth_noisy_png, ids_png, ids_noisy_png"
                                 : "NULL, NULL, NULL, NULL";
  Statement query_frames(
      &db_,
      "SELECT id, frame_index, seed, width, height, fx, fy, cx, cy, world_from_camera, " + images +
          ", content_hash FROM frames WHERE room_id = ? ORDER BY frame_index");
  Statement query_frame_objects(
      &db_,
      "SELECT instance_id, visible_pixels, amodal_pixels, visibility, visible_u0, "
      "visible_v0, visible_u1, visible_v1, amodal_u0, amodal_v0, amodal_u1, amodal_v1, "
      "in_frustum FROM frame_objects WHERE frame_id = ? ORDER BY instance_id");
  query_frames.Bind(1, room_id);
  while (query_frames.Step()) {
    FrameRecord frame;
    frame.id = query_frames.ColumnInt(0);
    frame.frame_index = static_cast<int>(query_frames.ColumnInt(1));
    frame.seed = AsUnsigned(query_frames.ColumnInt(2));
    frame.width = static_cast<int>(query_frames.ColumnInt(3));
    frame.height = static_cast<int>(query_frames.ColumnInt(4));
    frame.fx = query_frames.ColumnDouble(5);
    frame.fy = query_frames.ColumnDouble(6);
    frame.cx = query_frames.ColumnDouble(7);
    frame.cy = query_frames.ColumnDouble(8);
    frame.world_from_camera =
        ParsePose(query_frames.ColumnText(9), db_.path() + " frame " + std::to_string(frame.id));
    frame.depth_ideal_png = query_frames.ColumnBlob(10);
    frame.depth_noisy_png = query_frames.ColumnBlob(11);
    frame.ids_png = query_frames.ColumnBlob(12);
    frame.ids_noisy_png = query_frames.ColumnBlob(13);
    frame.content_hash = query_frames.ColumnText(14);
    query_frame_objects.Bind(1, frame.id);
    while (query_frame_objects.Step()) {
      FrameObjectRecord object;
      object.instance_id = static_cast<int>(query_frame_objects.ColumnInt(0));
      object.visible_pixels = query_frame_objects.ColumnInt(1);
      object.amodal_pixels = query_frame_objects.ColumnInt(2);
      object.visibility = query_frame_objects.ColumnDouble(3);
      for (int k = 0; k < 4; ++k)
        object.visible_box[k] = static_cast<int>(query_frame_objects.ColumnInt(4 + k));
      for (int k = 0; k < 4; ++k)
        object.amodal_box[k] = static_cast<int>(query_frame_objects.ColumnInt(8 + k));
      object.in_frustum = query_frame_objects.ColumnInt(12) != 0;
      frame.objects.push_back(object);
    }
    query_frame_objects.Reset();
    room.frames.push_back(std::move(frame));
  }
  return room;
}

void RemoveDatabaseFiles(const std::string& path) {
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path + suffix);
}

}  // namespace furn
