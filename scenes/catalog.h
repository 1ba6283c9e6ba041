// A furniture catalog: the entries a job can use, classified or not, and the
// way to load each one's model. Opened from a spec string:
//   "default"          the repo's class map over Debian's sweethome3d-furniture
//                      catalogs (the procedural catalog, with a warning, when
//                      the package is not installed);
//   "procedural[:SEED]" procedural furniture only;
//   "<file>.json"      a class map (see class_map.h);
//   "<file>.sh3f"      every entry of one Sweet Home 3D catalog, unclassified.
// Entries outside the class map stay available (room clutter) but have no
// class.
//
//   Catalog catalog = OpenCatalog("default", CatalogOpenOptions{});
//   for (const CatalogEntry* entry : catalog.Classified()) {
//     CadModel model = catalog.LoadModel(entry->id);
//   }
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry/mesh.h"
#include "core/model/furniture_class.h"
#include "core/util/data_dir.h"
#include "scenes/procedural_catalog.h"

namespace furn {

struct ClassMap;
struct ClassMapEntry;

class Sh3fCatalog;

struct CatalogEntry {
  std::string id;                                 // unique, e.g. "Scopia/chair3"
  std::string name;                               // e.g. "Chair"
  std::string category;                           // the catalog's own category, e.g. "Living room"
  std::string source;                             // .sh3f path, or "procedural:<seed>"
  std::optional<FurnitureClass> furniture_class;  // set for class-mapped entries
  bool evaluation_only = false;                   // never trained on
  bool vote_net_only = false;  // the vote network's training rooms alone (class_map.h)
  bool door_or_window = false;
  Eigen::Vector3f size_m = Eigen::Vector3f::Zero();  // width (x), depth (y), height (z)
};

struct ModelLoadFailure {
  std::string id;
  std::string message;
};

struct LoadedModels {
  std::vector<CadModel> models;            // in the order asked, failures left out
  std::vector<ModelLoadFailure> failures;  // reported, not fatal

  // For callers that need every model (training, generation): throws
  // InputError with the first failure's message.
  void RequireAll() const;
};

struct CatalogOpenOptions {
  // Where "default" and class maps find their .sh3f files.
  std::string catalog_dir = "/usr/share/sweethome3d/furniture";
  // Where "default" finds class_map.json.
  std::string data_dir = DefaultDataDir();  // core/util/data_dir.h
  // "default" falls back to the procedural catalog when catalog_dir lacks a
  // listed catalog; otherwise that is an error.
  bool allow_procedural_fallback = true;
};

class Catalog {
 public:
  Catalog();
  ~Catalog();
  Catalog(Catalog&&) noexcept;
  Catalog& operator=(Catalog&&) noexcept;

  // What was opened ("default", a path, ...), and a note when it fell back.
  const std::string& description() const { return description_; }
  const std::vector<std::string>& warnings() const { return warnings_; }

  const std::vector<CatalogEntry>& entries() const { return entries_; }
  std::vector<const CatalogEntry*> Classified() const;
  // Throws InputError naming the id (and close ids) when it is not in the
  // catalog.
  const CatalogEntry& Get(const std::string& id) const;

  // Adds `other`'s unclassified entries (not doors or windows, ids not
  // already here) as room clutter; its classified entries are left out.
  // Returns how many were added.
  int AddClutter(Catalog other);

  // A copy of the entries that shares this catalog's sources.
  Catalog Copy() const;

  // Adds models built in memory (procedural_shapes.h) as classified entries
  // of category `category`; ids already here are refused (InputError).
  // `what` is appended to the description ("default + <what>").
  void AddModels(std::vector<ProceduralModel> models,
                 const std::string& category,
                 const std::string& what);

  // Throws InputError naming the entry when its model cannot be loaded.
  CadModel LoadModel(const std::string& id) const;
  // Loads several in parallel, skipping (and reporting) entries that fail.
  LoadedModels LoadModels(const std::vector<std::string>& ids, bool show_progress = true) const;

 private:
  friend Catalog OpenCatalog(const std::string&, const CatalogOpenOptions&);
  struct Source;

  // Models built in memory as classified entries of a new source.
  void AppendPrebuilt(std::vector<ProceduralModel> models, const std::string& category);
  // A class map's steps (OpenCatalog): every entry of its .sh3f catalogs,
  // classified where the map names them; then its mesh-file entries, loaded
  // in parallel. Each takes the ids it classified out of *unmatched.
  void AppendMapCatalogs(const ClassMap& map,
                         const std::string& catalog_dir,
                         std::map<std::string, const ClassMapEntry*>* unmatched);
  void AppendMeshEntries(const ClassMap& map,
                         const std::string& class_map_path,
                         std::map<std::string, const ClassMapEntry*>* unmatched);

  std::string description_;
  std::vector<std::string> warnings_;
  std::vector<CatalogEntry> entries_;
  std::vector<int> source_of_entry_;  // index into sources_
  // Shared, never changed after opening: a Copy() loads from the same archives.
  std::vector<std::shared_ptr<const Source>> sources_;
};

// Throws InputError for an unknown spec, a missing or corrupt file, a class map
// naming an entry its catalogs do not have, or an unknown class.
Catalog OpenCatalog(const std::string& spec, const CatalogOpenOptions& options = {});

}  // namespace furn
