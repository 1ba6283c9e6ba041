// The class map: which catalog entries are detector classes, read from JSON.
//
//   {
//     "format": "furnidet-class-map", "version": 1,
//     "catalogs": ["Scopia.sh3f", "BlendSwap-CC-0.sh3f"],
//     "entries": [
//       {"id": "Scopia/chair3", "class": "chair"},
//       {"id": "BlendSwap-CC-0/table", "class": "table", "evaluation_only":
//       true}
//     ]
//   }
//
// "evaluation_only" entries are never trained on; evaluation reports them
// apart, to show how the method generalises to furniture it has not seen.
// An entry id is "<catalog file stem>/<id>" (see Sh3fEntry::id).
//
//   ClassMap map = LoadClassMap("data/class_map.json");
#pragma once

#include <string>
#include <vector>

#include "core/furniture_class.h"

namespace furn {

struct ClassMapEntry {
  std::string id;
  FurnitureClass furniture_class = FurnitureClass::kChair;
  bool evaluation_only = false;
};

struct ClassMap {
  std::string path;                   // where it was read from
  std::vector<std::string> catalogs;  // .sh3f file names, resolved against a catalog dir
  std::vector<ClassMapEntry> entries;
};

// Throws InputError naming the file and the rule: unreadable file, bad JSON,
// wrong format tag or version, no catalogs, no entries, an unknown class, an
// id that names no listed catalog, a duplicate id.
ClassMap LoadClassMap(const std::string& path);

// Same rules, on JSON text; `path` only names the source in messages.
ClassMap ParseClassMap(const std::string& json_text, const std::string& path);

}  // namespace furn
