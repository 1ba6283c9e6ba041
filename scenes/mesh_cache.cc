#include "scenes/mesh_cache.h"

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/util/file_util.h"

namespace furn {
namespace {

constexpr char kMagic[8] = {'F', 'U', 'R', 'N', 'M', 'S', 'H', '1'};
// Bump when the importer or the normalisation changes what it produces.
constexpr uint32_t kImporterVersion = 1;

template <typename T>
void Append(const T& value, std::string* out) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

}  // namespace

MeshCache MeshCache::FromEnvironment() {
  if (const char* explicit_dir = std::getenv("FURN_MESH_CACHE")) {
    const std::string dir = explicit_dir;
    return MeshCache(dir == "off" ? "" : dir);
  }
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return MeshCache(std::string(xdg) + "/furnidet/meshes");
  if (const char* home = std::getenv("HOME"); home && *home)
    return MeshCache(std::string(home) + "/.cache/furnidet/meshes");
  return MeshCache("");
}

std::optional<CachedMesh> MeshCache::Load(const std::string& key) const {
  if (!enabled()) return std::nullopt;
  std::ifstream file(directory_ + "/" + key + ".mesh", std::ios::binary);
  if (!file) return std::nullopt;
  const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const size_t header = sizeof(kMagic) + sizeof(uint32_t) + 32 + 2 * sizeof(uint64_t);
  if (bytes.size() < header || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
    return std::nullopt;
  size_t at = sizeof(kMagic);
  auto read = [&](void* out, size_t size) {
    std::memcpy(out, bytes.data() + at, size);
    at += size;
  };
  uint32_t version = 0;
  read(&version, sizeof(version));
  if (version != kImporterVersion) return std::nullopt;
  CachedMesh cached;
  cached.content_hash = bytes.substr(at, 32);
  at += 32;
  uint64_t vertices = 0, triangles = 0;
  read(&vertices, sizeof(vertices));
  read(&triangles, sizeof(triangles));
  if (vertices > bytes.size() || triangles > bytes.size() ||
      bytes.size() !=
          header + vertices * sizeof(Eigen::Vector3f) + triangles * sizeof(Eigen::Vector3i))
    return std::nullopt;
  cached.mesh.vertices.resize(vertices);
  cached.mesh.triangles.resize(triangles);
  read(cached.mesh.vertices.data(), vertices * sizeof(Eigen::Vector3f));
  read(cached.mesh.triangles.data(), triangles * sizeof(Eigen::Vector3i));
  if (HashMesh(cached.mesh) != cached.content_hash) return std::nullopt;  // damaged
  return cached;
}

void MeshCache::Store(const std::string& key, const CachedMesh& cached) const {
  if (!enabled() || cached.content_hash.size() != 32) return;
  std::string bytes(kMagic, sizeof(kMagic));
  Append(kImporterVersion, &bytes);
  bytes += cached.content_hash;
  Append(static_cast<uint64_t>(cached.mesh.vertices.size()), &bytes);
  Append(static_cast<uint64_t>(cached.mesh.triangles.size()), &bytes);
  bytes.append(reinterpret_cast<const char*>(cached.mesh.vertices.data()),
               cached.mesh.vertices.size() * sizeof(Eigen::Vector3f));
  bytes.append(reinterpret_cast<const char*>(cached.mesh.triangles.data()),
               cached.mesh.triangles.size() * sizeof(Eigen::Vector3i));
  try {
    std::error_code error;
    std::filesystem::create_directories(directory_, error);
    if (error) return;
    WriteFileAtomically(directory_ + "/" + key + ".mesh", bytes);
  } catch (const std::exception&) {
    // A cache that cannot be written only costs the speed-up.
  }
}

std::string MeshCacheKey(const std::string& content_digest, const std::string& import_parameters) {
  const std::string text = "content " + content_digest + '\n' + std::to_string(kImporterVersion) +
                           '\n' + import_parameters;
  ContentHasher hasher;
  hasher.Update(text.data(), text.size());
  return hasher.HexDigest();
}

}  // namespace furn
