// A disk cache of imported catalog meshes. Importing a Sweet Home 3D model
// (unzip, parse the OBJ, normalise) costs about 7 ms; every command that
// loads models repeats it, and `generate` spends a fifth of a 50-room run on
// it. The cache keeps the normalised mesh and its content hash under a key
// made of what the import depends on (the names, sizes and CRC-32s of the
// model's entries in the archive, the catalog's sizes and rotation, the
// importer's version), so a changed or replaced archive is imported afresh,
// even one of the same size and modification time, and a copy of an archive
// elsewhere shares the cache.
//
// Where: $FURN_MESH_CACHE ("off" disables it), else
// $XDG_CACHE_HOME/furnidet/meshes, else ~/.cache/furnidet/meshes. Files are
// written atomically (concurrent processes are safe); a damaged file is
// ignored and rewritten; an unwritable directory only costs the speed-up.
//
//   const MeshCache cache = MeshCache::FromEnvironment();
//   if (auto hit = cache.Load(key)) return *hit;
//   ... import ...; cache.Store(key, model);
#pragma once

#include <optional>
#include <string>

#include "core/geometry/mesh.h"

namespace furn {

struct CachedMesh {
  TriangleMesh mesh;
  std::string content_hash;  // HashMesh(mesh)
};

class MeshCache {
 public:
  // "" disables the cache.
  explicit MeshCache(std::string directory) : directory_(std::move(directory)) {}
  static MeshCache FromEnvironment();

  bool enabled() const { return !directory_.empty(); }
  const std::string& directory() const { return directory_; }

  // The mesh stored under `key`, or nothing when it is missing, from another
  // format version, truncated, or fails its hash.
  std::optional<CachedMesh> Load(const std::string& key) const;
  // Best effort: failures to write are ignored.
  void Store(const std::string& key, const CachedMesh& mesh) const;

 private:
  std::string directory_;
};

// The key of an import: 32 hex digits over what the source holds (e.g.
// ZipArchive::EntriesDigest of the model's folder), the importer's version
// and the given import parameters.
std::string MeshCacheKey(const std::string& content_digest, const std::string& import_parameters);

}  // namespace furn
