#include "workbench/pipelines/rooms_cache.h"

#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <set>

#include "core/geometry/mesh.h"  // ShortHash
#include "core/util/error.h"
#include "db/dataset_db.h"

namespace furn {
namespace {

// What the catalog contributes to the rooms: every entry (clutter too), and
// the size and modification time of each catalog file, so that an updated
// package makes new rooms.
std::string CatalogFingerprint(const Catalog& catalog) {
  std::string text = catalog.description() + "\n";
  std::set<std::string> sources;
  for (const CatalogEntry& entry : catalog.entries()) {
    char size[96];
    std::snprintf(
        size, sizeof(size), "%.6f %.6f %.6f", entry.size_m.x(), entry.size_m.y(), entry.size_m.z());
    text += entry.id + "|" + (entry.furniture_class ? ClassName(*entry.furniture_class) : "-") +
            "|" + (entry.evaluation_only ? "e" : "") + (entry.vote_net_only ? "v" : "") +
            (entry.door_or_window ? "d" : "") + "|" + size + "|" + entry.source + "\n";
    sources.insert(entry.source);
  }
  for (const std::string& source : sources) {
    struct stat info {};
    if (stat(source.c_str(), &info) != 0) continue;  // "procedural:<seed>", built in memory
    text += source + " " + std::to_string(info.st_size) + " " +
            std::to_string(info.st_mtim.tv_sec) + "." + std::to_string(info.st_mtim.tv_nsec) + "\n";
  }
  return text;
}

std::vector<std::string> FrameHashes(DatasetDb* db, int64_t room) {
  std::vector<std::string> hashes;
  for (const FrameRecord& frame : db->ReadRoom(room, /*with_images=*/false).frames)
    hashes.push_back(frame.content_hash);
  return hashes;
}

// Whether the cached file's first room is the room this program makes: it
// is made again alone (a shard of one room) beside the file and the frames'
// content hashes compared. True when the file holds no room yet.
bool SameGenerator(const std::string& path,
                   const Catalog& catalog,
                   const GenerateOptions& generate) {
  int64_t first = -1;
  {
    DatasetDb cached(path, DatasetDb::Mode::kReadOnly);
    const std::vector<int64_t> ids = cached.RoomIds();
    if (ids.empty()) return true;
    first = ids.front();
  }
  Require(first >= 0 && first < generate.rooms,
          path + ": holds room " + std::to_string(first) + ", outside the rooms 0.." +
              std::to_string(generate.rooms - 1) + " of its key");
  const std::string check_path = path + ".check.db";
  RemoveDatabaseFiles(check_path);
  GenerateOptions one = generate;
  one.shard_count = generate.rooms;
  one.shard_index = static_cast<int>(first);
  GenerateDataset(catalog, one, check_path);
  std::vector<std::string> made;
  {
    DatasetDb check(check_path, DatasetDb::Mode::kReadOnly);
    made = FrameHashes(&check, first);
  }
  RemoveDatabaseFiles(check_path);
  DatasetDb cached(path, DatasetDb::Mode::kReadOnly);
  return FrameHashes(&cached, first) == made;
}

// DIR/rooms-KEY.db, DIR made when missing.
std::string RoomsPathIn(const std::string& dir, const std::string& key) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  Require(std::filesystem::is_directory(dir),
          dir + ": cannot make the rooms cache's directory" +
              (error ? " (" + error.message() + ")" : std::string()));
  return dir + "/rooms-" + key + ".db";
}

}  // namespace

std::string RoomsCacheKey(const Catalog& catalog, const GenerateOptions& generate) {
  return ShortHash(generate.ContentJson() + "\n" + CatalogFingerprint(catalog));
}

CachedRooms::CachedRooms(const std::string& dir,
                         const Catalog& catalog,
                         const GenerateOptions& generate,
                         bool quiet)
    : path_(RoomsPathIn(dir, RoomsCacheKey(catalog, generate))),
      lock_(path_.substr(0, path_.size() - 3) + ".lock", "the rooms cache") {
  if (!std::filesystem::exists(path_)) return;
  bool same = false;
  try {
    same = SameGenerator(path_, catalog, generate);
  } catch (const std::runtime_error& error) {  // InputError, or SQLite's DbError
    throw InputError(std::string(error.what()) +
                     "; it is a file of the rooms cache: delete it to make the rooms again");
  }
  if (!same) {
    if (!quiet)
      std::fprintf(stderr,
                   "rooms cache: %s was made by another version of the generator (its first "
                   "room differs); making it again\n",
                   path_.c_str());
    RemoveDatabaseFiles(path_);
    return;
  }
  DatasetDb cached(path_, DatasetDb::Mode::kReadOnly);
  rooms_present_ = static_cast<int>(cached.RoomIds().size());
}

}  // namespace furn
