#include "scenes/catalog.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>

#include "core/util/error.h"
#include "core/util/parallel.h"
#include "core/util/progress.h"
#include "scenes/class_map.h"
#include "scenes/mesh_io.h"
#include "scenes/procedural_catalog.h"
#include "scenes/sh3f_catalog.h"

namespace furn {

// Where an entry's model comes from: a .sh3f archive, or models built when
// the catalog opened (procedural ones, mesh files of a class map).
struct Catalog::Source {
  std::unique_ptr<Sh3fCatalog> archive;      // set for .sh3f sources
  std::map<std::string, CadModel> prebuilt;  // procedural models and mesh files, by id
};

namespace {

constexpr char kProceduralPrefix[] = "procedural";

CatalogEntry EntryFromSh3f(const Sh3fEntry& sh3f, const std::string& source) {
  CatalogEntry entry;
  entry.id = sh3f.id;
  entry.name = sh3f.name;
  entry.category = sh3f.category;
  entry.source = source;
  entry.door_or_window = sh3f.door_or_window;
  entry.size_m = Eigen::Vector3f(sh3f.width_cm, sh3f.depth_cm, sh3f.height_cm) / 100.0f;
  return entry;
}

// What a class map says of an entry: its class and where it may appear.
void TakeMapFlags(const ClassMapEntry& mapped, CatalogEntry* entry) {
  entry->furniture_class = mapped.furniture_class;
  entry->evaluation_only = mapped.evaluation_only;
  entry->vote_net_only = mapped.vote_net_only;
}

bool AllCatalogsPresent(const ClassMap& map, const std::string& dir) {
  std::error_code ec;
  return std::all_of(map.catalogs.begin(), map.catalogs.end(), [&](const std::string& name) {
    return std::filesystem::is_regular_file(std::filesystem::path(dir) / name, ec);
  });
}

// Edit distance, for "did you mean" suggestions.
size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1])});
      diagonal = up;
    }
  }
  return row[b.size()];
}

uint64_t ParseSeed(const std::string& text, const std::string& spec) {
  Require(!text.empty() && text.find_first_not_of("0123456789") == std::string::npos &&
              text.size() <= 19,
          "catalog '" + spec + "': the seed after 'procedural:' must be a whole number");
  return std::stoull(text);
}

}  // namespace

void LoadedModels::RequireAll() const {
  if (!failures.empty()) throw InputError(failures.front().message);
}

Catalog::Catalog() = default;
Catalog::~Catalog() = default;
Catalog::Catalog(Catalog&&) noexcept = default;
Catalog& Catalog::operator=(Catalog&&) noexcept = default;

int Catalog::AddClutter(Catalog other) {
  std::set<std::string> ids;
  for (const CatalogEntry& entry : entries_) ids.insert(entry.id);
  const int first_source = static_cast<int>(sources_.size());
  int added = 0;
  for (size_t k = 0; k < other.entries_.size(); ++k) {
    CatalogEntry& entry = other.entries_[k];
    if (entry.furniture_class || entry.door_or_window || !ids.insert(entry.id).second) continue;
    entry.evaluation_only = false;
    entries_.push_back(std::move(entry));
    source_of_entry_.push_back(first_source + other.source_of_entry_[k]);
    ++added;
  }
  for (std::shared_ptr<const Source>& source : other.sources_)
    sources_.push_back(std::move(source));
  for (std::string& warning : other.warnings_) warnings_.push_back(std::move(warning));
  description_ += " + clutter of " + other.description_;
  return added;
}

Catalog Catalog::Copy() const {
  Catalog copy;
  copy.description_ = description_;
  copy.warnings_ = warnings_;
  copy.entries_ = entries_;
  copy.source_of_entry_ = source_of_entry_;
  copy.sources_ = sources_;
  return copy;
}

void Catalog::AddModels(std::vector<ProceduralModel> models,
                        const std::string& category,
                        const std::string& what) {
  AppendPrebuilt(std::move(models), category);
  description_ += " + " + what;
}

void Catalog::AppendPrebuilt(std::vector<ProceduralModel> models, const std::string& category) {
  std::set<std::string> ids;
  for (const CatalogEntry& entry : entries_) ids.insert(entry.id);
  auto source = std::make_shared<Source>();
  for (ProceduralModel& item : models) {
    Require(ids.insert(item.model.id).second,
            "catalog '" + description_ + "' already has an entry '" + item.model.id + "'");
    CatalogEntry entry;
    entry.id = item.model.id;
    entry.name = item.model.name;
    entry.category = category;
    entry.source = item.model.source_path;
    entry.furniture_class = item.furniture_class;
    entry.size_m = BoundingBox(item.model.mesh).Size();
    entries_.push_back(entry);
    source_of_entry_.push_back(static_cast<int>(sources_.size()));
    source->prebuilt.emplace(entry.id, std::move(item.model));
  }
  sources_.push_back(std::move(source));
}

std::vector<const CatalogEntry*> Catalog::Classified() const {
  std::vector<const CatalogEntry*> classified;
  for (const CatalogEntry& entry : entries_) {
    if (entry.furniture_class) classified.push_back(&entry);
  }
  return classified;
}

const CatalogEntry& Catalog::Get(const std::string& id) const {
  for (const CatalogEntry& entry : entries_) {
    if (entry.id == id) return entry;
  }
  std::vector<std::pair<size_t, std::string>> close;
  for (const CatalogEntry& entry : entries_) {
    close.emplace_back(EditDistance(id, entry.id), entry.id);
  }
  std::sort(close.begin(), close.end());
  std::string hint;
  for (size_t i = 0; i < std::min<size_t>(3, close.size()); ++i) {
    hint += (i ? ", " : " (closest: ") + close[i].second;
  }
  if (!hint.empty()) hint += ")";
  throw InputError("entry '" + id + "' is not in catalog " + description_ + hint);
}

CadModel Catalog::LoadModel(const std::string& id) const {
  const CatalogEntry& entry = Get(id);
  const size_t index = static_cast<size_t>(&entry - entries_.data());
  const Source& source = *sources_[source_of_entry_[index]];
  if (source.archive) return source.archive->LoadModel(*source.archive->Find(id));
  return source.prebuilt.at(id);
}

LoadedModels Catalog::LoadModels(const std::vector<std::string>& ids, bool show_progress) const {
  // Imported in parallel (zip reads are serialised, parsing is not), kept in
  // the order asked.
  std::vector<std::optional<CadModel>> models(ids.size());
  std::vector<std::string> errors(ids.size());
  Progress progress("load models", show_progress ? ids.size() : 0, "models");
  std::mutex progress_mutex;
  ParallelFor(0, static_cast<int>(ids.size()), [&](int i) {
    try {
      models[i] = LoadModel(ids[i]);
    } catch (const InputError& error) {
      errors[i] = error.what();
    }
    std::lock_guard<std::mutex> lock(progress_mutex);
    progress.Advance();
  });
  LoadedModels loaded;
  for (size_t i = 0; i < ids.size(); ++i) {
    if (models[i]) {
      loaded.models.push_back(std::move(*models[i]));
    } else {
      loaded.failures.push_back({ids[i], errors[i]});
    }
  }
  return loaded;
}

void Catalog::AppendMapCatalogs(const ClassMap& map,
                                const std::string& catalog_dir,
                                std::map<std::string, const ClassMapEntry*>* unmatched) {
  for (const std::string& file_name : map.catalogs) {
    const std::string path = (std::filesystem::path(catalog_dir) / file_name).string();
    auto source = std::make_shared<Source>();
    source->archive = std::make_unique<Sh3fCatalog>(path);
    for (const std::string& problem : source->archive->problems()) warnings_.push_back(problem);
    for (const Sh3fEntry& sh3f : source->archive->entries()) {
      CatalogEntry entry = EntryFromSh3f(sh3f, path);
      const auto it = unmatched->find(entry.id);
      if (it != unmatched->end()) {
        TakeMapFlags(*it->second, &entry);
        unmatched->erase(it);
      }
      entries_.push_back(std::move(entry));
      source_of_entry_.push_back(static_cast<int>(sources_.size()));
    }
    sources_.push_back(std::move(source));
  }
}

// Mesh-file entries (version 2): loaded here, in parallel, because rooms are
// composed from entry sizes and a mesh file declares none; kept as prebuilt
// models. One that does not load is skipped with a warning, as a .sh3f
// catalog skips a bad entry.
void Catalog::AppendMeshEntries(const ClassMap& map,
                                const std::string& class_map_path,
                                std::map<std::string, const ClassMapEntry*>* unmatched) {
  std::vector<const ClassMapEntry*> meshes;
  for (const ClassMapEntry& mapped : map.entries) {
    if (mapped.mesh.empty()) continue;
    for (const CatalogEntry& other : entries_) {
      Require(other.id != mapped.id,
              class_map_path + ": mesh entry '" + mapped.id + "' has the id of an entry of " +
                  other.source + "; give it another");
    }
    meshes.push_back(&mapped);
    unmatched->erase(mapped.id);
  }
  std::vector<std::optional<CadModel>> models(meshes.size());
  std::vector<std::string> errors(meshes.size());
  ParallelFor(0, static_cast<int>(meshes.size()), [&](int i) {
    try {
      models[i] = LoadMeshFile(meshes[i]->mesh, meshes[i]->mesh_options);
    } catch (const InputError& error) {
      errors[i] = error.what();
    }
  });
  auto source = std::make_shared<Source>();
  for (size_t i = 0; i < meshes.size(); ++i) {
    const ClassMapEntry& mapped = *meshes[i];
    if (!models[i]) {
      warnings_.push_back("skipped " + mapped.id + ": " + errors[i]);
      continue;
    }
    CatalogEntry entry;
    entry.id = mapped.id;
    entry.name = std::filesystem::path(mapped.mesh).stem().string();
    entry.category = "Mesh file";
    entry.source = mapped.mesh;
    TakeMapFlags(mapped, &entry);
    entry.size_m = BoundingBox(models[i]->mesh).Size();
    models[i]->id = entry.id;
    models[i]->name = entry.name;
    source->prebuilt.emplace(entry.id, std::move(*models[i]));
    entries_.push_back(std::move(entry));
    source_of_entry_.push_back(static_cast<int>(sources_.size()));
  }
  if (!source->prebuilt.empty()) sources_.push_back(std::move(source));
}

Catalog OpenCatalog(const std::string& spec, const CatalogOpenOptions& options) {
  Catalog catalog;
  catalog.description_ = spec;
  const std::string extension = std::filesystem::path(spec).extension().string();

  if (spec == kProceduralPrefix || spec.rfind(std::string(kProceduralPrefix) + ":", 0) == 0) {
    const uint64_t seed =
        spec == kProceduralPrefix ? 1 : ParseSeed(spec.substr(sizeof(kProceduralPrefix)), spec);
    ProceduralCatalogOptions procedural;
    procedural.seed = seed;
    catalog.AppendPrebuilt(MakeProceduralCatalog(procedural), "Procedural");
    return catalog;
  }

  if (extension == ".sh3f") {
    auto source = std::make_shared<Catalog::Source>();
    source->archive = std::make_unique<Sh3fCatalog>(spec);
    for (const Sh3fEntry& sh3f : source->archive->entries()) {
      catalog.entries_.push_back(EntryFromSh3f(sh3f, spec));
      catalog.source_of_entry_.push_back(0);
    }
    catalog.warnings_ = source->archive->problems();
    catalog.sources_.push_back(std::move(source));
    return catalog;
  }

  std::string class_map_path = spec;
  if (spec == "default") {
    Require(!options.data_dir.empty(),
            "catalog 'default' needs data/class_map.json: no share/furnidet/data was found beside "
            "this program (install it with cmake --install, or set FURN_DATA_DIR or --data-dir)");
    class_map_path = (std::filesystem::path(options.data_dir) / "class_map.json").string();
  } else {
    Require(extension == ".json",
            "unknown catalog '" + spec +
                "' (use default, procedural[:SEED], a class map .json "
                "or a .sh3f file)");
  }
  const ClassMap map = LoadClassMap(class_map_path);
  if (spec == "default" && options.allow_procedural_fallback &&
      !AllCatalogsPresent(map, options.catalog_dir)) {
    catalog = OpenCatalog("procedural", options);
    catalog.description_ = "default (procedural fallback)";
    catalog.warnings_.push_back("the Sweet Home 3D catalogs are not in " + options.catalog_dir +
                                " (apt-get install sweethome3d-furniture): using the "
                                "procedural catalog instead");
    return catalog;
  }

  std::map<std::string, const ClassMapEntry*> unmatched;
  for (const ClassMapEntry& entry : map.entries) unmatched[entry.id] = &entry;
  catalog.AppendMapCatalogs(map, options.catalog_dir, &unmatched);
  catalog.AppendMeshEntries(map, class_map_path, &unmatched);
  if (!unmatched.empty()) {
    const std::string id = unmatched.begin()->first;
    throw InputError(class_map_path + ": entry '" + id + "' does not exist in catalog " +
                     id.substr(0, id.find('/')) + ".sh3f (in " + options.catalog_dir + ")");
  }
  return catalog;
}

}  // namespace furn
