#include "workbench/dataset_commands.h"

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "db/dataset_db.h"
#include "reports/dataset_sheet.h"

namespace furn {
namespace {

DatasetDb OpenExisting(const std::string& db_path) {
  std::error_code ec;
  Require(std::filesystem::is_regular_file(db_path, ec), db_path + ": file does not exist");
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
    ++info.models_per_class[model.furniture_class.empty() ? "clutter" : model.furniture_class];
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
  return json.dump(2) + "\n";
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
