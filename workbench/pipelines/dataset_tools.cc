#include "workbench/pipelines/dataset_tools.h"

#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "reports/dataset_sheet.h"
#include "workbench/pipelines/export_bop.h"

namespace furn {
namespace {

DatasetDb OpenExisting(const std::string& db_path) {
  RequireRegularFile(db_path);
  std::error_code ec;
  Require(std::filesystem::exists(db_path, ec), db_path + ": file does not exist");
  return DatasetDb(db_path, DatasetDb::Mode::kReadOnly);
}

}  // namespace

DatasetInfo ReadDatasetInfo(const std::string& db_path) {
  DatasetDb dataset = OpenExisting(db_path);
  Database& db = *dataset.database();
  DatasetInfo info;
  info.path = db_path;
  info.file_bytes = static_cast<int64_t>(std::filesystem::file_size(db_path));
  info.generation_options = dataset.GenerationOptions().value_or("");
  Statement splits(&db, "SELECT split, count(*) FROM rooms GROUP BY split ORDER BY split");
  while (splits.Step())
    info.rooms_per_split[splits.ColumnText(0)] = static_cast<int>(splits.ColumnInt(1));
  Statement frames(&db, "SELECT count(*) FROM frames");
  frames.Step();
  info.frames = frames.ColumnInt(0);
  Statement objects(&db, "SELECT class, count(*) FROM objects GROUP BY class");
  while (objects.Step()) {
    if (objects.ColumnText(0).empty()) {
      info.clutter_objects = objects.ColumnInt(1);
    } else {
      info.objects_per_class[objects.ColumnText(0)] = objects.ColumnInt(1);
    }
  }
  Statement views(
      &db,
      "SELECT o.class, fo.visibility FROM frame_objects fo JOIN frames f ON f.id = fo.frame_id "
      "JOIN objects o ON o.room_id = f.room_id AND o.instance_id = fo.instance_id "
      "WHERE o.class != '' AND fo.in_frustum = 1");
  while (views.Step()) {
    ++info.views_per_class[views.ColumnText(0)];
    const int bin = std::min(9, static_cast<int>(views.ColumnDouble(1) * 10));
    ++info.visibility_histogram[bin];
  }
  for (const ModelRecord& model : dataset.ReadModels()) {
    ++info.models_per_class[model.furniture_class ? ClassName(*model.furniture_class) : "clutter"];
  }
  return info;
}

std::string DatasetInfoText(const DatasetInfo& info) {
  std::ostringstream out;
  int rooms = 0;
  for (const auto& [split, count] : info.rooms_per_split) rooms += count;
  out << info.path << ": " << rooms << " rooms (";
  bool first = true;
  for (const auto& [split, count] : info.rooms_per_split) {
    out << (first ? "" : ", ") << split << " " << count;
    first = false;
  }
  out << "), " << info.frames << " frames, " << (info.file_bytes + 512 * 1024) / (1024 * 1024)
      << " MiB\n";
  out << "objects placed: ";
  for (const auto& [name, count] : info.objects_per_class) out << name << " " << count << ", ";
  out << "clutter " << info.clutter_objects << "\n";
  out << "models used: ";
  first = true;
  for (const auto& [name, count] : info.models_per_class) {
    out << (first ? "" : ", ") << name << " " << count;
    first = false;
  }
  out << "\ntarget views in frustum: ";
  first = true;
  for (const auto& [name, count] : info.views_per_class) {
    out << (first ? "" : ", ") << name << " " << count;
    first = false;
  }
  int64_t total = 0;
  for (int64_t count : info.visibility_histogram) total += count;
  out << "\nvisibility histogram (target views):\n";
  for (int bin = 0; bin < 10; ++bin) {
    const int64_t count = info.visibility_histogram[bin];
    char line[96];
    std::snprintf(line,
                  sizeof(line),
                  "  %.1f-%.1f %7lld ",
                  bin / 10.0,
                  (bin + 1) / 10.0,
                  static_cast<long long>(count));
    out << line << std::string(total > 0 ? static_cast<size_t>(50.0 * count / total + 0.5) : 0, '#')
        << "\n";
  }
  return out.str();
}

std::string DatasetInfoJson(const DatasetInfo& info) {
  nlohmann::ordered_json json{
      {"path", info.path},
      {"file_bytes", info.file_bytes},
      {"rooms_per_split", info.rooms_per_split},
      {"frames", info.frames},
      {"objects_per_class", info.objects_per_class},
      {"clutter_objects", info.clutter_objects},
      {"models_per_class", info.models_per_class},
      {"target_views_per_class", info.views_per_class},
      {"visibility_histogram", info.visibility_histogram},
      {"generation_options",
       nlohmann::json::parse(info.generation_options.empty() ? "null" : info.generation_options)}};
  return json.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

void WriteDatasetPreview(const std::string& db_path, int max_frames, const std::string& png_path) {
  Require(max_frames >= 1 && max_frames <= 200,
          "--frames " + std::to_string(max_frames) + " must be in 1..200");
  DatasetDb dataset = OpenExisting(db_path);
  const std::vector<int64_t> room_ids = dataset.RoomIds();
  Require(!room_ids.empty(), db_path + ": the dataset has no rooms");
  std::vector<RoomRecord> rooms;
  for (int64_t id : room_ids) rooms.push_back(dataset.ReadRoom(id, /*with_images=*/false));
  std::vector<std::pair<size_t, size_t>> all;  // (room, frame)
  for (size_t r = 0; r < rooms.size(); ++r) {
    for (size_t f = 0; f < rooms[r].frames.size(); ++f) all.emplace_back(r, f);
  }
  Require(!all.empty(), db_path + ": the dataset has no frames");
  const size_t wanted = std::min(all.size(), static_cast<size_t>(max_frames));
  std::vector<RoomRecord> chosen_rooms;
  chosen_rooms.reserve(wanted);
  std::vector<SheetFrame> frames;
  for (size_t i = 0; i < wanted; ++i) {
    const auto [r, f] = all[i * all.size() / wanted];
    chosen_rooms.push_back(dataset.ReadRoom(rooms[r].id, /*with_images=*/true));
    RoomRecord& room = chosen_rooms.back();
    frames.push_back({&room.frames[f], &room});
  }
  WriteDatasetSheet(frames, DatasetSheetOptions{}, png_path);
}

}  // namespace furn

#include <fstream>

#include "core/geometry/scene.h"
#include "core/util/file_util.h"
#include "renderers/camera.h"
#include "workbench/formats/dataset_frame.h"  // IntrinsicsOf
#include "workbench/formats/depth_png.h"
#include "workbench/formats/detection_output.h"  // kConventionsText
#include "workbench/formats/point_cloud_file.h"
#include "workbench/formats/scan_file.h"

namespace furn {
namespace {

std::string SqlQuote(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace

namespace {

// Refuses inputs that lack rooms of the generation they come from (its
// options say how many rooms it made in all shards): a shard left out, or
// one whose task did not finish.
void CheckEveryRoomPresent(const std::string& generation_options,
                           const std::set<int64_t>& rooms,
                           const std::string& remedy) {
  const nlohmann::json options = nlohmann::json::parse(generation_options, nullptr, false);
  if (!options.is_object() || !options.contains("rooms") || !options["rooms"].is_number_integer())
    return;  // not a generated dataset (an imported real set)
  const int64_t made = options["rooms"].get<int64_t>();
  std::string missing;
  int listed = 0;
  for (int64_t id = 0; id < made && listed < 5; ++id) {
    if (rooms.count(id)) continue;
    missing += (listed++ ? ", " : "") + std::to_string(id);
  }
  Require(
      missing.empty(),
      "the inputs hold " + std::to_string(rooms.size()) + " of the " + std::to_string(made) +
          " rooms of their generation (missing room " + missing +
          (listed < static_cast<int>(made - static_cast<int64_t>(rooms.size())) ? ", ..." : "") +
          ": a shard left out, or one whose task did not finish)" + remedy);
}

}  // namespace

std::string CheckMergeable(const std::vector<std::string>& inputs,
                           const std::string& remedy,
                           bool allow_partial) {
  Require(inputs.size() >= 1, "merge needs at least one input dataset");
  std::string options;
  std::set<int64_t> rooms;
  for (const std::string& input : inputs) {
    DatasetDb dataset = OpenExisting(input);
    const std::string these = dataset.GenerationOptions().value_or("");
    if (options.empty()) options = these;
    Require(these == options,
            input + ": generated with other options than " + inputs.front() +
                " (only shards of one run can be merged)");
    for (int64_t id : dataset.RoomIds()) rooms.insert(id);
  }
  if (!allow_partial) CheckEveryRoomPresent(options, rooms, remedy);
  return options;
}

MergeSummary MergeDatasets(const std::vector<std::string>& inputs,
                           const std::string& out,
                           bool allow_partial) {
  std::error_code ec;
  Require(!std::filesystem::exists(out, ec), out + ": already exists (merge writes a new file)");
  const std::string options = CheckMergeable(
      inputs, allow_partial ? "" : "; --allow-partial merges them anyway", allow_partial);
  const std::string temp = out + ".partial";
  // The temporary file is removed before writing: never one of the inputs.
  auto same_file = [](const std::string& a, const std::string& b) {
    std::error_code ea, eb;
    const auto x = std::filesystem::weakly_canonical(a, ea),
               y = std::filesystem::weakly_canonical(b, eb);
    return ea || eb ? std::filesystem::absolute(a) == std::filesystem::absolute(b) : x == y;
  };
  for (const std::string& input : inputs) {
    Require(!same_file(input, temp),
            input + ": is the file merge writes its work in (" + temp +
                "); give --out another name, or rename the input first");
  }
  std::filesystem::remove(temp, ec);
  MergeSummary summary;
  try {
    DatasetDb merged(temp, DatasetDb::Mode::kReadWrite);
    merged.SetGenerationOptions(options);
    Database& db = *merged.database();
    for (const std::string& input : inputs) {
      {
        DatasetDb source = OpenExisting(input);
        merged.WriteModels(source.ReadModels());
      }
      db.Execute("ATTACH DATABASE " + SqlQuote(input) + " AS source");
      int64_t conflicting = 0;
      {  // statements on `source` must be finished before it is detached
        Statement conflicts(
            &db,
            "SELECT count(*) FROM source.rooms s JOIN main.rooms m ON m.id = s.id "
            "WHERE m.seed != s.seed OR EXISTS (SELECT 1 FROM source.frames sf JOIN main.frames mf "
            "ON mf.id = sf.id WHERE sf.room_id = s.id AND sf.content_hash != mf.content_hash)");
        conflicts.Step();
        conflicting = conflicts.ColumnInt(0);
        Statement duplicates(
            &db, "SELECT count(*) FROM source.rooms WHERE id IN (SELECT id FROM main.rooms)");
        duplicates.Step();
        summary.duplicate_rooms += static_cast<int>(duplicates.ColumnInt(0));
      }
      if (conflicting > 0) {
        throw InputError(input + ": " + std::to_string(conflicting) +
                         " rooms have the same id as rooms already merged but other content");
      }
      Transaction transaction(&db);
      db.Execute(
          "INSERT INTO main.rooms SELECT * FROM source.rooms WHERE id NOT IN (SELECT id FROM "
          "main.rooms)");
      db.Execute(
          "INSERT INTO main.objects SELECT * FROM source.objects WHERE (room_id, instance_id) NOT "
          "IN "
          "(SELECT room_id, instance_id FROM main.objects)");
      db.Execute(
          "INSERT INTO main.frames SELECT * FROM source.frames WHERE id NOT IN (SELECT id FROM "
          "main.frames)");
      db.Execute(
          "INSERT INTO main.frame_objects SELECT * FROM source.frame_objects WHERE (frame_id, "
          "instance_id) NOT IN "
          "(SELECT frame_id, instance_id FROM main.frame_objects)");
      transaction.Commit();
      db.Execute("DETACH DATABASE source");
    }
    summary.rooms = static_cast<int>(merged.RoomIds().size());
    db.Execute("PRAGMA wal_checkpoint(TRUNCATE)");
  } catch (...) {
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(temp + suffix, ec);
    throw;
  }
  std::filesystem::rename(temp, out, ec);
  Require(!ec, out + ": cannot write (" + ec.message() + ")");
  std::filesystem::remove(temp + "-wal", ec);
  std::filesystem::remove(temp + "-shm", ec);
  return summary;
}

namespace {

void WriteBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()));
}

std::string Pad(int64_t value) {
  char text[16];
  std::snprintf(text, sizeof(text), "%06lld", static_cast<long long>(value));
  return text;
}

// A frame's camera and ground truth as the png and pcd exports write them
// (docs/datasets.md): REP 103 boxes in the world (floor z = 0), the pose as
// four rows, each object's instance id (= the pixel label) and visibility.
nlohmann::ordered_json FrameLabelsJson(const RoomRecord& room, const FrameRecord& frame) {
  nlohmann::ordered_json objects = nlohmann::ordered_json::array();
  for (const ObjectRecord& object : room.objects) {
    double visibility = 0;  // not listed: out of view
    for (const FrameObjectRecord& seen : frame.objects) {
      if (seen.instance_id == object.instance_id) visibility = seen.visibility;
    }
    const OrientedBox box = WorldBoxOf(object.Footprint(), 0, object.height);
    objects.push_back(
        {{"label", object.instance_id},
         {"class",
          object.furniture_class ? nlohmann::ordered_json(ClassName(*object.furniture_class))
                                 : nlohmann::ordered_json(nullptr)},
         {"model", object.model_id},
         {"centre", {box.centre.x(), box.centre.y(), box.centre.z()}},
         {"size", {box.size.x(), box.size.y(), box.size.z()}},
         {"yaw", box.yaw},
         {"visibility", visibility}});
  }
  return {{"frame", frame.id},
          {"room", room.id},
          {"split", EnumName(room.split)},
          {"width", frame.width},
          {"height", frame.height},
          {"K", {{frame.fx, 0, frame.cx}, {0, frame.fy, frame.cy}, {0, 0, 1}}},
          {"world_from_camera", PoseRows(frame.world_from_camera)},
          {"objects", objects}};
}

// What every exported labels file says about its numbers.
nlohmann::ordered_json ExportHeader(const char* format) {
  return {{"format", format},
          {"version", 2},
          {"conventions",
           std::string(kConventionsText) +
               "; camera: optical (x right, y down, z ahead); label = the instance id the pixel "
               "shows: an object's (its \"label\"), the room's (\"structure_labels\") or 0"},
          {"structure_labels", {{"floor", kFloorId}, {"wall", kWallId}}}};
}

std::string JsonText(const nlohmann::ordered_json& json) {
  return json.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace

int ExportDataset(const std::string& db_path,
                  const std::string& format,
                  const std::string& out_dir,
                  const CatalogOpenOptions& catalog_options) {
  Require(format == "bop" || format == "png" || format == "pcd",
          "export format '" + format + "' is not one of bop, png, pcd");
  OpenExisting(db_path);
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  Require(std::filesystem::is_directory(out_dir, ec),
          out_dir + ": cannot create the output directory");
  if (format == "bop") return ExportBop(db_path, out_dir, BopExportOptions{catalog_options});
  DatasetDb dataset = OpenExisting(db_path);
  const std::filesystem::path root(out_dir);
  nlohmann::ordered_json png_frames = nlohmann::ordered_json::array();
  int written = 0;
  for (int64_t room_id : dataset.RoomIds()) {
    const RoomRecord room = dataset.ReadRoom(room_id, /*with_images=*/true);
    for (const FrameRecord& frame : room.frames) {
      const std::string where = db_path + " frame " + std::to_string(frame.id);
      nlohmann::ordered_json labels = FrameLabelsJson(room, frame);
      if (format == "pcd") {
        DepthFrame noisy = DecodeDepthPng(frame.depth_noisy_png, where);
        DecodeIdPng(frame.ids_png, where + " ids", &noisy);
        WriteOrganizedPcd(noisy,
                          IntrinsicsOf(frame),
                          (root / (Pad(frame.id) + ".pcd")).string(),
                          frame.world_from_camera);
        nlohmann::ordered_json sidecar = ExportHeader("furnidet-pcd-labels");
        sidecar.update(labels);
        sidecar["cloud"] = Pad(frame.id) + ".pcd";
        WriteFileAtomically((root / (Pad(frame.id) + ".json")).string(), JsonText(sidecar));
      } else {
        std::filesystem::create_directories(root / "frames", ec);
        const std::string stem = "frames/" + Pad(frame.id);
        WriteBytes((root / (stem + "_depth.png")).string(), frame.depth_noisy_png);
        WriteBytes((root / (stem + "_depth_ideal.png")).string(), frame.depth_ideal_png);
        WriteBytes((root / (stem + "_ids.png")).string(), frame.ids_png);
        labels["depth"] = stem + "_depth.png";
        labels["depth_ideal"] = stem + "_depth_ideal.png";
        labels["ids"] = stem + "_ids.png";
        labels["depth_unit_m"] = 0.001;
        png_frames.push_back(std::move(labels));
      }
      ++written;
    }
  }
  if (format == "png") {
    nlohmann::ordered_json index = ExportHeader("furnidet-png-export");
    index["frames"] = std::move(png_frames);
    WriteFileAtomically((root / "frames.json").string(), JsonText(index));
  }
  return written;
}

}  // namespace furn
