// The work behind `workbench catalog ...`, as functions tests call directly.
//
//   Catalog catalog = OpenCatalog("default");
//   CatalogListing listing = ListCatalog(catalog, ListCatalogOptions{});
//   std::cout << FormatCatalogTable(listing);
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/furniture_class.h"
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
