#include "workbench/pipelines/catalog_tools.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "scenes/mesh_io.h"

namespace furn {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;

std::string FormatSize(const Eigen::Vector3f& size) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.2fx%.2fx%.2f", size.x(), size.y(), size.z());
  return text;
}

std::string ClassText(const CatalogEntry& entry) {
  return entry.furniture_class ? ClassName(*entry.furniture_class) : "-";
}

ordered_json SizeJson(const Eigen::Vector3f& size) {
  return ordered_json{{"width", size.x()}, {"depth", size.y()}, {"height", size.z()}};
}

}  // namespace

CatalogListing ListCatalog(const Catalog& catalog, const ListCatalogOptions& options) {
  CatalogListing listing;
  listing.description = catalog.description();
  listing.warnings = catalog.warnings();
  for (const CatalogEntry& entry : catalog.entries()) {
    if (!options.all_entries && !entry.furniture_class) continue;
    if (options.only_class && entry.furniture_class != options.only_class) continue;
    CatalogListingRow row;
    row.entry = &entry;
    listing.rows.push_back(row);
  }
  // Classified entries first, grouped by class; catalog order within a group.
  auto rank = [](const CatalogListingRow& row) {
    return row.entry->furniture_class ? static_cast<int>(*row.entry->furniture_class) : 99;
  };
  std::stable_sort(
      listing.rows.begin(),
      listing.rows.end(),
      [&](const CatalogListingRow& a, const CatalogListingRow& b) { return rank(a) < rank(b); });
  if (!options.load_models) return listing;
  std::vector<std::string> ids;
  for (const CatalogListingRow& row : listing.rows) ids.push_back(row.entry->id);
  LoadedModels loaded = catalog.LoadModels(ids);
  std::map<std::string, const CadModel*> by_id;
  for (const CadModel& model : loaded.models) by_id[model.id] = &model;
  for (CatalogListingRow& row : listing.rows) {
    const auto it = by_id.find(row.entry->id);
    if (it == by_id.end()) continue;
    row.triangles = it->second->mesh.NumTriangles();
    row.content_hash = it->second->content_hash;
    row.mesh_size_m = BoundingBox(it->second->mesh).Size();
  }
  listing.failures = std::move(loaded.failures);
  return listing;
}

std::string FormatCatalogTable(const CatalogListing& listing) {
  size_t id_width = 2;
  for (const CatalogListingRow& row : listing.rows)
    id_width = std::max(id_width, row.entry->id.size());
  const bool loaded =
      std::any_of(listing.rows.begin(), listing.rows.end(), [](const CatalogListingRow& r) {
        return r.triangles.has_value();
      });
  std::ostringstream out;
  char line[512];
  std::snprintf(line,
                sizeof(line),
                "%-*s  %-9s  %-16s  %s%s\n",
                static_cast<int>(id_width),
                "ID",
                "CLASS",
                "W x D x H (m)",
                loaded ? "TRIANGLES  " : "",
                "NAME (CATEGORY)");
  out << line;
  std::map<std::string, int> per_class;
  size_t total_triangles = 0;
  for (const CatalogListingRow& row : listing.rows) {
    const CatalogEntry& entry = *row.entry;
    std::string triangles;
    if (loaded) {
      triangles = row.triangles ? std::to_string(*row.triangles) : "FAILED";
      triangles.resize(std::max<size_t>(triangles.size(), 9), ' ');
      triangles += "  ";
      total_triangles += row.triangles.value_or(0);
    }
    std::snprintf(
        line,
        sizeof(line),
        "%-*s  %-9s  %-16s  %s%s (%s)%s\n",
        static_cast<int>(id_width),
        entry.id.c_str(),
        ClassText(entry).c_str(),
        // Mesh-file entries declare no size: their mesh's, once loaded.
        FormatSize(entry.size_m.isZero() && loaded ? row.mesh_size_m : entry.size_m).c_str(),
        triangles.c_str(),
        entry.name.c_str(),
        entry.category.c_str(),
        entry.evaluation_only ? " [evaluation only]"
        : entry.vote_net_only ? " [vote net only]"
                              : "");
    out << line;
    ++per_class[ClassText(entry)];
  }
  out << listing.rows.size() << " entries in catalog " << listing.description << ":";
  for (const auto& [name, count] : per_class) out << " " << count << " " << name;
  if (loaded) {
    out << "; " << (listing.rows.size() - listing.failures.size()) << " models loaded, "
        << total_triangles << " triangles, " << listing.failures.size() << " skipped";
  }
  out << "\n";
  return out.str();
}

std::string CatalogListingToJson(const CatalogListing& listing) {
  ordered_json entries = ordered_json::array();
  for (const CatalogListingRow& row : listing.rows) {
    const CatalogEntry& entry = *row.entry;
    ordered_json item{
        {"id", entry.id},
        {"class", entry.furniture_class ? json(ClassName(*entry.furniture_class)) : json()},
        {"name", entry.name},
        {"category", entry.category},
        {"size_m", SizeJson(entry.size_m)},
        {"evaluation_only", entry.evaluation_only},
        {"vote_net_only", entry.vote_net_only},
        {"source", entry.source}};
    if (row.triangles) {
      item["triangles"] = *row.triangles;
      item["content_hash"] = row.content_hash;
      item["mesh_size_m"] = SizeJson(row.mesh_size_m);
    }
    entries.push_back(item);
  }
  ordered_json failures = ordered_json::array();
  for (const ModelLoadFailure& failure : listing.failures) {
    failures.push_back({{"id", failure.id}, {"error", failure.message}});
  }
  ordered_json document{{"catalog", listing.description},
                        {"warnings", listing.warnings},
                        {"entries", entries},
                        {"failures", failures}};
  return document.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

std::string DescribeModel(const CatalogEntry& entry, const CadModel& model, bool as_json) {
  const Box3 box = BoundingBox(model.mesh);
  if (as_json) {
    ordered_json document{
        {"id", entry.id},
        {"name", entry.name},
        {"class", entry.furniture_class ? json(ClassName(*entry.furniture_class)) : json()},
        {"category", entry.category},
        {"evaluation_only", entry.evaluation_only},
        {"vote_net_only", entry.vote_net_only},
        {"source_path", model.source_path},
        {"catalog_size_m", SizeJson(entry.size_m)},
        {"mesh_size_m", SizeJson(box.Size())},
        {"mesh_min_z", box.min.z()},
        {"triangles", model.mesh.NumTriangles()},
        {"vertices", model.mesh.vertices.size()},
        {"surface_area_m2", SurfaceArea(model.mesh)},
        {"content_hash", model.content_hash}};
    return document.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  }
  std::ostringstream out;
  out << "id:            " << entry.id << "\n"
      << "name:          " << entry.name << "\n"
      << "class:         " << ClassText(entry)
      << (entry.evaluation_only ? " (evaluation only)" : "")
      << (entry.vote_net_only ? " (vote net only)" : "") << "\n"
      << "category:      " << entry.category << "\n"
      << "source:        " << model.source_path << "\n"
      << "catalog size:  " << FormatSize(entry.size_m) << " m (width x depth x height)\n"
      << "mesh size:     " << FormatSize(box.Size()) << " m, base at z = " << box.min.z() << "\n"
      << "triangles:     " << model.mesh.NumTriangles() << " (" << model.mesh.vertices.size()
      << " vertices)\n"
      << "surface area:  " << SurfaceArea(model.mesh) << " m^2\n"
      << "content hash:  " << model.content_hash << "\n";
  return out.str();
}

}  // namespace furn

namespace furn {
namespace {

// "Chairs", "chair", "ARMCHAIRS" -> the class; "clutter" -> nullopt with
// *clutter set. Throws naming the folder otherwise.
std::optional<FurnitureClass> ClassOfFolder(const std::string& folder, bool* clutter) {
  std::string name = folder;
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  if (name.size() > 1 && name.back() == 's') name.pop_back();
  *clutter = name == "clutter";
  if (*clutter) return std::nullopt;
  for (FurnitureClass furniture_class : kAllClasses) {
    if (name == ClassName(furniture_class)) return furniture_class;
  }
  throw InputError("folder '" + folder + "' names no class (" + EnumNameList<FurnitureClass>() +
                   ", clutter; plural or not): give --class");
}

// The unit under which the model's height is that of furniture (0.2 to 3 m).
std::pair<std::string, double> GuessUnits(float height_in_file_units) {
  static const std::pair<const char*, double> kUnits[] = {
      {"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}};
  for (const auto& [name, metres] : kUnits) {
    const double height = height_in_file_units * metres;
    if (height >= 0.2 && height <= 3.0) return {name, metres};
  }
  return {"m", 1.0};
}

std::string AxisText(const Eigen::Vector3f& axis) {
  int index = 0;
  axis.cwiseAbs().maxCoeff(&index);
  return std::string(axis[index] < 0 ? "-" : "+") + "xyz"[index];
}

// A chair's back rises above its seat: the centroid of what lies above 60 %
// of the height sits towards the back, and the front is the other way.
// Returns the engine-frame front, or nullopt when the top is centred.
std::optional<Eigen::Vector3f> GuessFrontFromBack(const TriangleMesh& mesh) {
  const Box3 box = BoundingBox(mesh);
  const float cut = box.min.z() + 0.6f * (box.max.z() - box.min.z());
  Eigen::Vector2f sum = Eigen::Vector2f::Zero();
  double weight = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) {  // area-weighted, so dense parts do not win
    const Eigen::Vector3f& a = mesh.vertices[t[0]];
    const Eigen::Vector3f& b = mesh.vertices[t[1]];
    const Eigen::Vector3f& c = mesh.vertices[t[2]];
    const Eigen::Vector3f centre = (a + b + c) / 3;
    if (centre.z() < cut) continue;
    const float area = 0.5f * (b - a).cross(c - a).norm();
    sum += area * centre.head<2>();
    weight += area;
  }
  if (weight <= 0) return std::nullopt;
  const Eigen::Vector2f offset = sum / weight - (box.min + box.max).head<2>() / 2;
  const Eigen::Vector2f extent = (box.max - box.min).head<2>();
  const Eigen::Vector2f relative = offset.cwiseQuotient(extent.cwiseMax(1e-6f));
  int axis = 0;
  relative.cwiseAbs().maxCoeff(&axis);
  if (std::abs(relative[axis]) < 0.08f) return std::nullopt;
  Eigen::Vector3f front = Eigen::Vector3f::Zero();
  front[axis] = relative[axis] > 0 ? -1.f : 1.f;  // away from the back
  return front;
}

}  // namespace

namespace {

// The mesh files of a folder and below, sorted: every assimp format and VTK
// legacy polydata; side files of other formats (materials, textures) are
// not models.
// A mesh file name that is no regular file (a FIFO, a device or a link to
// one) goes to `not_regular`: the import says it skipped it.
std::vector<std::filesystem::path> MeshFilesIn(const std::string& dir,
                                               std::vector<std::filesystem::path>* not_regular) {
  std::error_code ec;
  const std::vector<std::string> assimp = SupportedImportExtensions();
  std::vector<std::filesystem::path> files;
  for (const std::filesystem::directory_entry& entry :
       std::filesystem::recursive_directory_iterator(dir, ec)) {
    if (entry.is_directory()) continue;
    const std::string extension = FileExtension(entry.path().string());
    if (extension != "vtk" &&
        (extension == "mtl" || !std::binary_search(assimp.begin(), assimp.end(), extension)))
      continue;
    (entry.is_regular_file() ? files : *not_regular).push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  std::sort(not_regular->begin(), not_regular->end());
  return files;
}

// One file's class map entry: its class (or clutter), units guessed from its
// height, up axis the format's, front from a back rest for seats. The model
// loaded by the caller (`model`, in file units).
ImportedMesh DescribeMesh(const std::filesystem::path& file,
                          CadModel model,
                          std::optional<FurnitureClass> furniture_class,
                          bool clutter,
                          const std::filesystem::path& out_folder) {
  ImportedMesh mesh;
  const std::string path = file.string();
  mesh.id = file.parent_path().filename().string() + "/" + file.stem().string();
  mesh.class_name = clutter ? "clutter" : ClassName(*furniture_class);
  const auto [units, metres] = GuessUnits(BoundingBox(model.mesh).Size().z());
  mesh.units = units;
  TransformMesh(static_cast<float>(metres) * Eigen::Matrix3f::Identity(),
                Eigen::Vector3f::Zero(),
                &model.mesh);
  mesh.size_m = BoundingBox(model.mesh).Size();
  const bool y_up = LoadsYUpByDefault(FileExtension(path));
  mesh.up = y_up ? "y" : "z";
  const Eigen::Matrix3f engine_from_file = y_up ? ZUpFromYUp() : Eigen::Matrix3f::Identity();
  Eigen::Vector3f front = engine_from_file.transpose() * Eigen::Vector3f(0, -1, 0);
  mesh.note = "units " + mesh.units + (metres == 1.0 ? "" : " (guessed from the height)");
  if (!clutter &&
      (furniture_class == FurnitureClass::kChair || furniture_class == FurnitureClass::kArmchair ||
       furniture_class == FurnitureClass::kSofa)) {
    if (const auto guessed = GuessFrontFromBack(model.mesh)) {
      front = engine_from_file.transpose() * *guessed;
      mesh.note += "; front guessed from the back rest";
    } else {
      mesh.note += "; front not guessed (no back rest found): check it";
    }
  } else {
    mesh.note += "; front is the format's: check it";
  }
  mesh.front = AxisText(front);
  std::error_code ec;
  mesh.mesh =
      std::filesystem::relative(std::filesystem::absolute(file), out_folder, ec).generic_string();
  if (ec || mesh.mesh.empty()) mesh.mesh = std::filesystem::absolute(file).string();
  return mesh;
}

}  // namespace

MeshFolderImport ImportMeshFolder(const MeshFolderImportOptions& options) {
  namespace fs = std::filesystem;
  std::error_code ec;
  Require(fs::is_directory(options.dir, ec), options.dir + ": no such folder");
  Require(options.overwrite || !fs::exists(options.out, ec),
          options.out + ": exists; give --overwrite to replace it (a class map may hold edits)");
  std::vector<fs::path> not_regular;
  const std::vector<fs::path> files = MeshFilesIn(options.dir, &not_regular);
  Require(!files.empty(),
          options.dir +
              ": no mesh file (vtk, obj, ply, stl, off, gltf, glb, "
              "dae, fbx, 3ds, ...) in this folder or below");
  const fs::path out_folder = fs::absolute(fs::path(options.out)).parent_path();
  MeshFolderImport import;
  for (const fs::path& file : not_regular) {
    import.skipped.push_back({file.parent_path().filename().string() + "/" + file.stem().string(),
                              file.string() + ": not a regular file (a FIFO, device or a link "
                                              "to one)"});
  }
  ordered_json entries = ordered_json::array();
  for (const fs::path& file : files) {
    // The class from the options or the file's folder (an unknown folder is
    // an error before the file loads).
    const std::string folder = file.parent_path().filename().string();
    std::optional<FurnitureClass> furniture_class = options.furniture_class;
    bool clutter = options.clutter;
    if (!furniture_class && !clutter) furniture_class = ClassOfFolder(folder, &clutter);
    CadModel model;
    try {
      model = LoadMeshFile(file.string());
    } catch (const InputError& error) {
      import.skipped.push_back({folder + "/" + file.stem().string(), error.what()});
      continue;
    }
    ImportedMesh mesh = DescribeMesh(file, std::move(model), furniture_class, clutter, out_folder);
    entries.push_back(ordered_json{{"id", mesh.id},
                                   {"class", mesh.class_name},
                                   {"mesh", mesh.mesh},
                                   {"units", mesh.units},
                                   {"up", mesh.up},
                                   {"front", mesh.front},
                                   {"note", mesh.note + "; " + FormatSize(mesh.size_m) + " m"}});
    import.meshes.push_back(std::move(mesh));
  }
  if (import.meshes.empty()) {  // files were found, so some were skipped
    throw InputError(options.dir + ": no mesh loaded (first: " + import.skipped.front().message +
                     ")");
  }
  std::set<std::string> ids;
  for (const ImportedMesh& mesh : import.meshes) {
    Require(ids.insert(mesh.id).second,
            options.dir + ": two files give the id '" + mesh.id + "' (same folder and stem)");
  }
  const ordered_json map = {{"format", "furnidet-class-map"}, {"version", 2}, {"entries", entries}};
  WriteFileAtomically(options.out,
                      map.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  return import;
}

std::string FormatMeshImport(const MeshFolderImport& import, const std::string& out) {
  std::ostringstream text;
  size_t id_width = 2;
  for (const ImportedMesh& mesh : import.meshes) id_width = std::max(id_width, mesh.id.size());
  char line[512];
  std::snprintf(line,
                sizeof(line),
                "%-*s  %-9s  %-16s  %-5s  %-3s  %-5s\n",
                static_cast<int>(id_width),
                "ID",
                "CLASS",
                "W x D x H (m)",
                "UNITS",
                "UP",
                "FRONT");
  text << line;
  for (const ImportedMesh& mesh : import.meshes) {
    std::snprintf(line,
                  sizeof(line),
                  "%-*s  %-9s  %-16s  %-5s  %-3s  %-5s\n",
                  static_cast<int>(id_width),
                  mesh.id.c_str(),
                  mesh.class_name.c_str(),
                  FormatSize(mesh.size_m).c_str(),
                  mesh.units.c_str(),
                  mesh.up.c_str(),
                  mesh.front.c_str());
    text << line;
  }
  for (const ModelLoadFailure& skipped : import.skipped)
    text << "skipped " << skipped.id << ": " << skipped.message << "\n";
  text << "wrote " << out << ": " << import.meshes.size()
       << " mesh entries; check fronts and sizes with: workbench catalog sheet --catalog " << out
       << " --all --out sheet.png\n";
  return text.str();
}

}  // namespace furn
