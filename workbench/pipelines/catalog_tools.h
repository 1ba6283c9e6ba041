// The work behind `workbench catalog ...`, as functions tests call directly.
//
//   Catalog catalog = OpenCatalog("default");
//   CatalogListing listing = ListCatalog(catalog, ListCatalogOptions{});
//   std::cout << FormatCatalogTable(listing);
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/model/furniture_class.h"
#include "scenes/catalog.h"

namespace furn {

struct ListCatalogOptions {
  bool all_entries = false;  // false: classified entries only
  std::optional<FurnitureClass> only_class;
  bool load_models = false;  // import every listed model (triangles, hash, failures)
};

struct CatalogListingRow {
  const CatalogEntry* entry = nullptr;
  // Set when models were loaded and this one loaded.
  std::optional<size_t> triangles;
  std::string content_hash;
  Eigen::Vector3f mesh_size_m = Eigen::Vector3f::Zero();
};

struct CatalogListing {
  std::string description;
  std::vector<std::string> warnings;
  std::vector<CatalogListingRow> rows;
  std::vector<ModelLoadFailure> failures;  // skipped models (when loading)
};

CatalogListing ListCatalog(const Catalog& catalog, const ListCatalogOptions& options);

// An aligned text table plus a per-class summary line.
std::string FormatCatalogTable(const CatalogListing& listing);
std::string CatalogListingToJson(const CatalogListing& listing);

// `catalog show`: every fact about one entry and its loaded model.
std::string DescribeModel(const CatalogEntry& entry, const CadModel& model, bool as_json);

}  // namespace furn

namespace furn {

// `catalog import DIR`: a starter class map (version 2) for a folder of mesh
// files, to be checked on `catalog sheet` and edited.
struct MeshFolderImportOptions {
  std::string dir;  // searched recursively for every loadable mesh format
  // The class of every mesh; unset: from each file's folder name ("Chairs",
  // "chair", "Tables", ...; "clutter" too). Throws when a folder names none.
  std::optional<FurnitureClass> furniture_class;
  bool clutter = false;  // every mesh a clutter entry instead
  std::string out;       // the class map to write (mesh paths relative to it)
  bool overwrite = false;
};

struct ImportedMesh {
  std::string id;    // "<folder>/<file stem>"
  std::string mesh;  // relative to the class map
  std::string class_name;
  std::string units;  // m, cm, mm or in: the one that gives a plausible height
  std::string up;     // the format's up axis
  std::string front;  // file axis the piece faces; guessed for chairs and armchairs
  Eigen::Vector3f size_m = Eigen::Vector3f::Zero();  // after units and axes
  std::string note;                                  // how units and front were chosen
};

struct MeshFolderImport {
  std::vector<ImportedMesh> meshes;
  std::vector<ModelLoadFailure> skipped;  // files that did not load, with the reason
};

// Reads every mesh under options.dir, guesses units and front, and writes the
// class map atomically. Throws InputError for a missing folder, a folder
// without a loadable mesh, an existing output (without overwrite) or a
// folder name that is no class.
MeshFolderImport ImportMeshFolder(const MeshFolderImportOptions& options);

std::string FormatMeshImport(const MeshFolderImport& import, const std::string& out);

}  // namespace furn
