#include "scenes/class_map.h"

#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "core/error.h"
#include "core/file_util.h"

namespace furn {
namespace {

using nlohmann::json;

constexpr char kFormat[] = "furnidet-class-map";
constexpr int kVersion = 1;

std::string CatalogStem(const std::string& file_name) {
  return std::filesystem::path(file_name).stem().string();
}

ClassMapEntry ParseEntry(const json& item, size_t position, const std::string& where) {
  const std::string at = where + ": entries[" + std::to_string(position) + "]";
  Require(item.is_object(), at + " must be an object with \"id\" and \"class\"");
  for (const auto& [key, value] : item.items()) {
    Require(key == "id" || key == "class" || key == "evaluation_only" || key == "note",
            at + " has unknown field '" + key + "' (allowed: id, class, evaluation_only, note)");
  }
  Require(item.contains("id") && item["id"].is_string() && !item["id"].get<std::string>().empty(),
          at + " needs a non-empty string \"id\"");
  Require(item.contains("class") && item["class"].is_string(), at + " needs a string \"class\"");
  ClassMapEntry entry;
  entry.id = item["id"].get<std::string>();
  try {
    entry.furniture_class = ParseFurnitureClass(item["class"].get<std::string>());
  } catch (const InputError& error) {
    throw InputError(where + ": entry '" + entry.id + "' has " + error.what());
  }
  if (item.contains("evaluation_only")) {
    Require(item["evaluation_only"].is_boolean(),
            at + " \"evaluation_only\" must be true or false");
    entry.evaluation_only = item["evaluation_only"].get<bool>();
  }
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
              document["version"].get<int64_t>() == kVersion,
          path + ": unsupported class map version (this build reads version " +
              std::to_string(kVersion) + ")");
  ClassMap map;
  map.path = path;
  Require(document.contains("catalogs") && document["catalogs"].is_array() &&
              !document["catalogs"].empty(),
          path + ": \"catalogs\" must list at least one .sh3f file");
  std::set<std::string> stems;
  for (const json& catalog : document["catalogs"]) {
    Require(catalog.is_string(), path + ": every item of \"catalogs\" must be a file name");
    map.catalogs.push_back(catalog.get<std::string>());
    stems.insert(CatalogStem(map.catalogs.back()));
  }
  Require(document.contains("entries") && document["entries"].is_array(),
          path + ": \"entries\" must be an array");
  Require(!document["entries"].empty(), path + ": the class map names no entries");
  std::set<std::string> ids;
  for (size_t i = 0; i < document["entries"].size(); ++i) {
    ClassMapEntry entry = ParseEntry(document["entries"][i], i, path);
    const std::string stem = entry.id.substr(0, entry.id.find('/'));
    Require(entry.id.find('/') != std::string::npos && stems.count(stem) > 0,
            path + ": entry '" + entry.id + "' names no listed catalog (ids are " +
                "\"<catalog stem>/<entry>\" with the stem of a file in "
                "\"catalogs\")");
    Require(ids.insert(entry.id).second, path + ": entry '" + entry.id + "' is listed twice");
    map.entries.push_back(std::move(entry));
  }
  return map;
}

ClassMap LoadClassMap(const std::string& path) { return ParseClassMap(ReadFileBytes(path), path); }

}  // namespace furn
