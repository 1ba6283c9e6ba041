// A directory of vote-network training rooms kept by what decides them
// (`train`/`crossval --rooms-cache DIR`): a training whose rooms would be the
// same — another network width, loss, schedule or decoding on the same fold
// — reuses them instead of composing and rendering them again.
//
// The key hashes the rooms' generation options (GenerateOptions::ContentJson:
// seed, room count, sensor, held-out models, ...) and the catalog: its
// entries and the size and time of each catalog file. A program whose
// composer or renderer changed would make other rooms under the same key, so
// a cached file is reused only when its first room, made again, has the same
// frames (their content hashes); otherwise it is made again, with a line
// saying so. A file left by a killed run resumes (GenerateDataset).
//
//   const CachedRooms rooms(dir, catalog, generate);  // locked while it lives
//   GenerateDataset(catalog, generate, rooms.path());  // nothing to do when complete
#pragma once

#include <string>

#include "scenes/catalog.h"
#include "workbench/pipelines/file_lock.h"
#include "workbench/pipelines/generate.h"

namespace furn {

// The key of the rooms `generate` makes from `catalog` (16 hex digits).
std::string RoomsCacheKey(const Catalog& catalog, const GenerateOptions& generate);

class CachedRooms {
 public:
  // Makes `dir` when missing and locks DIR/rooms-KEY.lock until destroyed
  // (another process or thread asking for the same rooms waits). `quiet`:
  // no line when a stale file is made again.
  CachedRooms(const std::string& dir,
              const Catalog& catalog,
              const GenerateOptions& generate,
              bool quiet = false);

  // DIR/rooms-KEY.db: complete, partial (resumes) or not yet there.
  const std::string& path() const { return path_; }
  // Rooms already in the file when it was opened (after the check).
  int rooms_present() const { return rooms_present_; }

 private:
  std::string path_;
  FileLock lock_;
  int rooms_present_ = 0;
};

}  // namespace furn
