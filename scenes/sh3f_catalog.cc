#include "scenes/sh3f_catalog.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "core/util/error.h"
#include "scenes/java_properties.h"
#include "scenes/mesh_cache.h"
#include "scenes/mesh_io.h"
#include "scenes/zip_archive.h"

namespace furn {
namespace {

constexpr char kPropertiesName[] = "PluginFurnitureCatalog.properties";

// Numbers N that appear as a "key#N" suffix.
std::set<int> EntryIndices(const std::map<std::string, std::string>& properties) {
  std::set<int> indices;
  for (const auto& [key, value] : properties) {
    const size_t hash = key.rfind('#');
    if (hash == std::string::npos || hash + 1 == key.size()) continue;
    const std::string suffix = key.substr(hash + 1);
    if (suffix.find_first_not_of("0123456789") != std::string::npos || suffix.size() > 9) continue;
    indices.insert(std::stoi(suffix));
  }
  return indices;
}

// Parses a finite number; throws InputError naming `what`.
float ParseNumber(const std::string& text, const std::string& what) {
  std::istringstream stream(text);
  stream.imbue(std::locale::classic());
  double value = 0;
  stream >> value;
  Require(!stream.fail() && std::isfinite(value) && (stream >> std::ws).eof(),
          what + " '" + text + "' is not a number");
  return static_cast<float>(value);
}

Eigen::Matrix3f ParseRotation(const std::string& text, const std::string& what) {
  std::istringstream stream(text);
  std::vector<std::string> items;
  std::string item;
  while (stream >> item) items.push_back(item);
  Require(items.size() == 9, what + " '" + text + "' must have 9 numbers (row-major 3x3)");
  Eigen::Matrix3f rotation;
  for (int i = 0; i < 9; ++i) rotation(i / 3, i % 3) = ParseNumber(items[i], what);
  return rotation;
}

Sh3fEntry ParseEntry(const std::map<std::string, std::string>& properties,
                     int index,
                     const std::string& stem,
                     const std::string& where) {
  const std::string suffix = "#" + std::to_string(index);
  auto get = [&](const std::string& key) {
    const auto it = properties.find(key + suffix);
    return it == properties.end() ? std::string() : it->second;
  };
  const std::string entry_where = where + " entry " + std::to_string(index);
  Sh3fEntry entry;
  entry.index = index;
  entry.sh3d_id = get("id");
  const size_t hash = entry.sh3d_id.rfind('#');
  const std::string local_id = entry.sh3d_id.empty()       ? std::to_string(index)
                               : hash == std::string::npos ? entry.sh3d_id
                                                           : entry.sh3d_id.substr(hash + 1);
  entry.id = stem + "/" + local_id;
  entry.name = get("name");
  entry.category = get("category");
  entry.creator = get("creator");
  entry.model_path = get("model");
  Require(!entry.model_path.empty(),
          entry_where + " (" + entry.id + "): no model" + suffix + " key");
  while (!entry.model_path.empty() && entry.model_path[0] == '/') entry.model_path.erase(0, 1);
  entry.width_cm = ParseNumber(get("width"), entry_where + " width" + suffix);
  entry.depth_cm = ParseNumber(get("depth"), entry_where + " depth" + suffix);
  entry.height_cm = ParseNumber(get("height"), entry_where + " height" + suffix);
  Require(entry.width_cm > 0 && entry.depth_cm > 0 && entry.height_cm > 0,
          entry_where + " (" + entry.id + "): width, depth and height must be > 0 cm");
  const std::string elevation = get("elevation");
  if (!elevation.empty()) {
    entry.elevation_cm = ParseNumber(elevation, entry_where + " elevation" + suffix);
  }
  const std::string rotation = get("modelRotation");
  if (!rotation.empty()) {
    entry.model_rotation = ParseRotation(rotation, entry_where + " modelRotation" + suffix);
  }
  entry.door_or_window = get("doorOrWindow") == "true";
  return entry;
}

}  // namespace

TriangleMesh NormalizeSweetHome3dMesh(TriangleMesh mesh,
                                      const Eigen::Matrix3f& model_rotation,
                                      float width_cm,
                                      float depth_cm,
                                      float height_cm,
                                      const std::string& where) {
  TransformMesh(model_rotation, Eigen::Vector3f::Zero(), &mesh);
  const Eigen::Vector3f size = BoundingBox(mesh).Size();
  // Sweet Home 3D's axes: x = width, y = height (up), z = depth.
  const Eigen::Vector3f target_m = Eigen::Vector3f(width_cm, height_cm, depth_cm) / 100.0f;
  const char* axis_names[3] = {"width (x)", "height (y)", "depth (z)"};
  for (int axis = 0; axis < 3; ++axis) {
    Require(size[axis] > 1e-9f,
            where + ": model is flat along its " + axis_names[axis] +
                " and cannot be scaled to the catalog size");
  }
  const Eigen::Matrix3f scale = target_m.cwiseQuotient(size).asDiagonal();
  TransformMesh(ZUpFromYUp() * scale, Eigen::Vector3f::Zero(), &mesh);
  PlaceOnFloorCentred(&mesh);
  return mesh;
}

Sh3fCatalog::Sh3fCatalog(const std::string& path)
    : path_(path), stem_(std::filesystem::path(path).stem().string()) {
  std::error_code ec;
  Require(std::filesystem::exists(path, ec), path + ": file does not exist");
  zip_ = std::make_unique<ZipArchive>(path);
  Require(zip_->Contains(kPropertiesName),
          path + ": no " + std::string(kPropertiesName) + " in the archive (not a .sh3f catalog)");
  const auto properties = ParseJavaProperties(zip_->Read(kPropertiesName));
  std::set<std::string> seen_ids;
  for (int index : EntryIndices(properties)) {
    try {
      Sh3fEntry entry = ParseEntry(properties, index, stem_, path);
      if (!seen_ids.insert(entry.id).second) {
        problems_.push_back(path + " entry " + std::to_string(index) + ": duplicate id " +
                            entry.id);
        continue;
      }
      entries_.push_back(std::move(entry));
    } catch (const InputError& error) {
      problems_.push_back(error.what());
    }
  }
  // With no usable entry, the first entry's problem is the reason to give.
  Require(
      !entries_.empty(),
      path + ": " + kPropertiesName + " declares no usable models" +
          (problems_.empty() ? std::string(" (no model#N entries)")
                             : " (" + problems_.front() +
                                   (problems_.size() > 1
                                        ? "; and " + std::to_string(problems_.size() - 1) + " more"
                                        : std::string()) +
                                   ")"));
}

Sh3fCatalog::~Sh3fCatalog() = default;

const Sh3fEntry* Sh3fCatalog::Find(const std::string& id) const {
  for (const Sh3fEntry& entry : entries_) {
    if (entry.id == id) return &entry;
  }
  return nullptr;
}

CadModel Sh3fCatalog::LoadModel(const Sh3fEntry& entry) const {
  const std::string where = path_ + " entry " + entry.id;
  // What the import depends on besides the archive itself.
  std::ostringstream parameters;
  parameters.precision(9);
  parameters << entry.model_path << '\n'
             << entry.width_cm << ' ' << entry.depth_cm << ' ' << entry.height_cm << '\n'
             << entry.model_rotation.format(Eigen::IOFormat(Eigen::FullPrecision));
  // The model's folder in the archive (its OBJ and MTL files), by content.
  std::string folder = entry.model_path;
  if (!folder.empty() && folder[0] == '/') folder.erase(0, 1);
  folder.erase(folder.rfind('/') == std::string::npos ? 0 : folder.rfind('/') + 1);
  const std::string key = MeshCacheKey(zip_->EntriesDigest(folder), parameters.str());
  CadModel model;
  model.id = entry.id;
  model.name = entry.name;
  model.source_path = path_ + "!/" + entry.model_path;
  if (std::optional<CachedMesh> cached = mesh_cache_.Load(key)) {
    model.mesh = std::move(cached->mesh);
    model.content_hash = std::move(cached->content_hash);
    return model;
  }
  TriangleMesh raw;
  try {
    raw = ImportMeshFromZip(*zip_, entry.model_path);
  } catch (const InputError& error) {
    throw InputError(where + ": " + error.what());
  }
  model.mesh = NormalizeSweetHome3dMesh(
      std::move(raw), entry.model_rotation, entry.width_cm, entry.depth_cm, entry.height_cm, where);
  model.content_hash = HashMesh(model.mesh);
  mesh_cache_.Store(key, CachedMesh{model.mesh, model.content_hash});
  return model;
}

}  // namespace furn
