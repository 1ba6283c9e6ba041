#include "scenes/class_map.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {
namespace {

using nlohmann::json;

constexpr char kFormat[] = "furnidet-class-map";
constexpr int kNewestVersion = 2;

std::string CatalogStem(const std::string& file_name) {
  return std::filesystem::path(file_name).stem().string();
}

std::string StringField(const json& item, const char* key, const std::string& at) {
  Require(item[key].is_string(), at + " \"" + key + "\" must be a string");
  return item[key].get<std::string>();
}

// units, up, front and size of a mesh entry; the file resolved against the
// class map's folder and required to exist.
void ParseMeshFields(const json& item,
                     const std::string& at,
                     const std::filesystem::path& folder,
                     ClassMapEntry* entry) {
  const std::filesystem::path mesh(StringField(item, "mesh", at));
  Require(!mesh.empty(), at + " \"mesh\" must name a file");
  entry->mesh = (mesh.is_absolute() ? mesh : folder / mesh).lexically_normal().string();
  RequireRegularFile(entry->mesh);
  std::error_code ec;
  Require(std::filesystem::exists(entry->mesh, ec),
          at + " \"mesh\": " + entry->mesh + " does not exist");
  MeshLoadOptions& options = entry->mesh_options;
  if (item.contains("units")) {
    options.metres_per_unit = item["units"].is_number()
                                  ? item["units"].get<double>()
                                  : ParseUnits(StringField(item, "units", at), at + " \"units\"");
    // From a micrometre to a kilometre per unit: beyond, a number is a typo
    // (1e300 made a mesh of size -inf).
    Require(std::isfinite(options.metres_per_unit) && options.metres_per_unit >= 1e-6 &&
                options.metres_per_unit <= 1e3,
            at + " \"units\" must be m, cm, mm, in, ft or a positive number of metres per unit "
                 "(1e-6..1000)");
  }
  std::optional<Eigen::Vector3f> up, front;
  if (item.contains("up")) up = ParseAxis(StringField(item, "up", at), at + " \"up\"");
  if (item.contains("front")) front = ParseAxis(StringField(item, "front", at), at + " \"front\"");
  if (up || front) {
    // A front alone keeps the format's up axis.
    const bool y_up_format = LoadsYUpByDefault(FileExtension(entry->mesh));
    const Eigen::Vector3f up_axis =
        up ? *up : (y_up_format ? Eigen::Vector3f::UnitY() : Eigen::Vector3f::UnitZ());
    options.engine_from_file =
        AxesFromUpAndFront(up_axis, front ? *front : DefaultFront(up_axis), at);
  }
  if (item.contains("size")) {
    const json& size = item["size"];
    Require(size.is_array() && size.size() == 3 &&
                std::all_of(size.begin(),
                            size.end(),
                            [](const json& v) {
                              return v.is_number() && std::isfinite(v.get<double>()) &&
                                     v.get<double>() > 0;
                            }),
            at + " \"size\" must be [width, depth, height]: three positive lengths in metres");
    options.size_m =
        Eigen::Vector3f(size[0].get<float>(), size[1].get<float>(), size[2].get<float>());
  }
}

ClassMapEntry ParseEntry(const json& item,
                         size_t position,
                         const std::string& where,
                         int version,
                         const std::filesystem::path& folder) {
  const std::string at = where + ": entries[" + std::to_string(position) + "]";
  Require(item.is_object(), at + " must be an object with \"id\" and \"class\"");
  static const std::set<std::string> kCatalogKeys = {
      "id", "class", "evaluation_only", "vote_net_only", "note"};
  static const std::set<std::string> kMeshKeys = {"mesh", "units", "up", "front", "size"};
  for (const auto& [key, value] : item.items()) {
    if (kCatalogKeys.count(key) > 0) continue;
    Require(kMeshKeys.count(key) > 0,
            at + " has unknown field '" + key +
                "' (allowed: id, class, evaluation_only, vote_net_only, note; mesh, units, up, "
                "front, size)");
    Require(version >= 2,
            at + " field '" + key + "' needs class map version 2 (mesh-file entries)");
    Require(item.contains("mesh"), at + " field '" + key + "' belongs to a \"mesh\" entry");
  }
  Require(item.contains("id") && item["id"].is_string() && !item["id"].get<std::string>().empty(),
          at + " needs a non-empty string \"id\"");
  Require(item.contains("class") && item["class"].is_string(), at + " needs a string \"class\"");
  ClassMapEntry entry;
  entry.id = item["id"].get<std::string>();
  const std::string class_name = item["class"].get<std::string>();
  if (class_name != "clutter" || version < 2) {
    try {
      entry.furniture_class = ParseFurnitureClass(class_name);
    } catch (const InputError& error) {
      throw InputError(where + ": entry '" + entry.id + "' has " + error.what() +
                       (version >= 2 ? " (or \"clutter\")" : ""));
    }
  }
  if (item.contains("evaluation_only")) {
    Require(item["evaluation_only"].is_boolean(),
            at + " \"evaluation_only\" must be true or false");
    entry.evaluation_only = item["evaluation_only"].get<bool>();
  }
  if (item.contains("vote_net_only")) {
    Require(item["vote_net_only"].is_boolean(), at + " \"vote_net_only\" must be true or false");
    entry.vote_net_only = item["vote_net_only"].get<bool>();
    Require(!(entry.vote_net_only && entry.evaluation_only),
            at + " is \"evaluation_only\" and \"vote_net_only\": one excludes the other");
    Require(!entry.vote_net_only || entry.furniture_class.has_value(),
            at + " \"vote_net_only\" needs a detector class, not clutter");
  }
  if (item.contains("note") && item["note"].is_string())
    entry.note = item["note"].get<std::string>();
  if (item.contains("mesh"))
    ParseMeshFields(item, where + ": entry '" + entry.id + "'", folder, &entry);
  return entry;
}

}  // namespace

ClassMap ParseClassMap(const std::string& json_text, const std::string& path) {
  json document;
  try {
    document = json::parse(json_text);
  } catch (const json::parse_error& error) {
    throw InputError(path + ": not valid JSON (" + error.what() + ")");
  }
  Require(document.is_object(), path + ": a class map must be a JSON object");
  Require(document.contains("format") && document["format"].is_string() &&
              document["format"].get<std::string>() == kFormat,
          path + ": \"format\" must be \"" + kFormat + "\"");
  Require(document.contains("version") && document["version"].is_number_integer() &&
              document["version"].get<int64_t>() >= 1 &&
              document["version"].get<int64_t>() <= kNewestVersion,
          path + ": unsupported class map version (this build reads versions 1 and " +
              std::to_string(kNewestVersion) + ")");
  ClassMap map;
  map.path = path;
  map.version = static_cast<int>(document["version"].get<int64_t>());
  if (map.version == 1 || document.contains("catalogs")) {
    Require(document.contains("catalogs") && document["catalogs"].is_array() &&
                (map.version >= 2 || !document["catalogs"].empty()),
            path + ": \"catalogs\" must list at least one .sh3f file");
  }
  std::set<std::string> stems;
  if (document.contains("catalogs")) {
    for (const json& catalog : document["catalogs"]) {
      Require(catalog.is_string(), path + ": every item of \"catalogs\" must be a file name");
      map.catalogs.push_back(catalog.get<std::string>());
      stems.insert(CatalogStem(map.catalogs.back()));
    }
  }
  Require(document.contains("entries") && document["entries"].is_array(),
          path + ": \"entries\" must be an array");
  Require(!document["entries"].empty(), path + ": the class map names no entries");
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::set<std::string> ids;
  for (size_t i = 0; i < document["entries"].size(); ++i) {
    ClassMapEntry entry = ParseEntry(document["entries"][i], i, path, map.version, folder);
    const std::string stem = entry.id.substr(0, entry.id.find('/'));
    Require(
        !entry.mesh.empty() || (entry.id.find('/') != std::string::npos && stems.count(stem) > 0),
        path + ": entry '" + entry.id + "' names no listed catalog (ids are " +
            "\"<catalog stem>/<entry>\" with the stem of a file in \"catalogs\"" +
            (map.version >= 2 ? ", or the entry names a \"mesh\" file)" : ")"));
    Require(ids.insert(entry.id).second, path + ": entry '" + entry.id + "' is listed twice");
    map.entries.push_back(std::move(entry));
  }
  return map;
}

ClassMap LoadClassMap(const std::string& path) { return ParseClassMap(ReadFileBytes(path), path); }

}  // namespace furn
