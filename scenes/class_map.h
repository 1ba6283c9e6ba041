// The class map: which catalog entries are detector classes, read from JSON.
//
//   {
//     "format": "furnidet-class-map", "version": 1,
//     "catalogs": ["Scopia.sh3f", "BlendSwap-CC-0.sh3f"],
//     "entries": [
//       {"id": "Scopia/chair3", "class": "chair"},
//       {"id": "BlendSwap-CC-0/table", "class": "table", "evaluation_only": true}
//     ]
//   }
//
// "evaluation_only" entries are never trained on; evaluation reports them
// apart, to show how the method generalises to furniture it has not seen.
// "vote_net_only" entries are more CAD variety for the learned vote map
// alone: its training rooms place them, but the codebook does not learn
// them, evaluation rooms never show them and protocol E's folds leave them
// out, so that datasets, folds and the codebook's figures stay what they
// were without them.
// An entry id is "<catalog file stem>/<id>" (see Sh3fEntry::id).
//
// Version 2 adds entries that are mesh files of their own (any assimp format
// or VTK legacy polydata), paths relative to the class map's folder, with
// what a file does not say about itself; "catalogs" may then be left out:
//
//   {"format": "furnidet-class-map", "version": 2,
//    "entries": [
//      {"id": "paper/chair1", "class": "chair", "mesh": "models/chair1.vtk",
//       "units": "m", "up": "z", "front": "-y"},
//      {"id": "mine/lamp", "class": "clutter", "mesh": "lamp.obj", "units": "cm",
//       "size": [0.3, 0.3, 1.6]},
//      {"id": "Scopia/chair3", "class": "chair"}],
//    "catalogs": ["Scopia.sh3f"]}
//
// "units": m, cm, mm, in, ft or metres per unit (default m); "up": the file
// axis that points up (x, y, z, signed; default: the format's, see
// mesh_io.h); "front": the file axis the piece faces (default: -y for z up,
// +z for y up); "size": [width, depth, height] in metres to scale to;
// "class": "clutter" for a distractor that is never a target.
//
//   ClassMap map = LoadClassMap("data/class_map.json");
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/model/furniture_class.h"
#include "scenes/mesh_io.h"

namespace furn {

struct ClassMapEntry {
  std::string id;
  std::optional<FurnitureClass> furniture_class;  // unset: "clutter"
  bool evaluation_only = false;
  bool vote_net_only = false;
  // Version 2 mesh-file entries: the file (resolved against the class map's
  // folder) and how to bring it to the engine's units and axes; empty for
  // entries of a listed catalog.
  std::string mesh;
  MeshLoadOptions mesh_options;
  std::string note;
};

struct ClassMap {
  std::string path;  // where it was read from
  int version = 1;
  std::vector<std::string> catalogs;  // .sh3f file names, resolved against a catalog dir
  std::vector<ClassMapEntry> entries;
};

// Throws InputError naming the file and the rule: unreadable file, bad JSON,
// wrong format tag or version, no catalogs (version 1), no entries, an unknown
// class, an id that names no listed catalog (catalog entries), a duplicate id,
// and for mesh entries an unknown unit or axis, a front not perpendicular to
// up, a bad size or a missing mesh file.
ClassMap LoadClassMap(const std::string& path);

// Same rules, on JSON text; `path` only names the source in messages.
ClassMap ParseClassMap(const std::string& json_text, const std::string& path);

}  // namespace furn
