#include "workbench/catalog_commands.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

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
        entry.evaluation_only ? " [evaluation only]" : "");
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
  return document.dump(2) + "\n";
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
        {"source_path", model.source_path},
        {"catalog_size_m", SizeJson(entry.size_m)},
        {"mesh_size_m", SizeJson(box.Size())},
        {"mesh_min_z", box.min.z()},
        {"triangles", model.mesh.NumTriangles()},
        {"vertices", model.mesh.vertices.size()},
        {"surface_area_m2", SurfaceArea(model.mesh)},
        {"content_hash", model.content_hash}};
    return document.dump(2) + "\n";
  }
  std::ostringstream out;
  out << "id:            " << entry.id << "\n"
      << "name:          " << entry.name << "\n"
      << "class:         " << ClassText(entry)
      << (entry.evaluation_only ? " (evaluation only)" : "") << "\n"
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
