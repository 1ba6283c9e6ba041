#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "core/util/error.h"
#include "core/util/progress.h"
#include "reports/mesh_sheet.h"
#include "scenes/mesh_io.h"
#include "scenes/procedural_shapes.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/commands.h"
#include "workbench/cli/enum_option.h"
#include "workbench/pipelines/catalog_tools.h"

namespace furn {
namespace {

void PrintWarnings(const std::vector<std::string>& warnings) {
  for (const std::string& warning : warnings)
    std::fprintf(stderr, "warning: %s\n", warning.c_str());
}

void PrintFailures(const std::vector<ModelLoadFailure>& failures) {
  for (const ModelLoadFailure& failure : failures) {
    std::fprintf(stderr, "skipped %s: %s\n", failure.id.c_str(), failure.message.c_str());
  }
}

// Class, size and name under a sheet tile: the catalog's size, or the mesh's
// for entries that declare none (mesh files of a class map).
std::string SheetSubtitle(const CatalogEntry& entry, const CadModel& model) {
  const Eigen::Vector3f size_m =
      entry.size_m.isZero() ? BoundingBox(model.mesh).Size() : entry.size_m;
  char size[64];
  std::snprintf(size, sizeof(size), " %.2fx%.2fx%.2f m", size_m.x(), size_m.y(), size_m.z());
  return (entry.furniture_class ? ClassName(*entry.furniture_class) : std::string("-")) + size +
         " " + entry.name;
}

// The listed entries drawn as a contact sheet; returns how many.
int DrawCatalogSheet(const Catalog& catalog,
                     const ListCatalogOptions& list_options,
                     const MeshSheetOptions& sheet_options,
                     const std::string& out_path) {
  const CatalogListing listing = ListCatalog(catalog, list_options);
  Require(!listing.rows.empty(), "catalog " + catalog.description() + " has no entries to draw");
  std::vector<std::string> ids;
  for (const CatalogListingRow& row : listing.rows) ids.push_back(row.entry->id);
  const LoadedModels loaded = catalog.LoadModels(ids);
  PrintFailures(loaded.failures);
  std::vector<SheetTile> tiles;
  for (const CadModel& model : loaded.models) {
    tiles.push_back({&model.mesh, model.id, SheetSubtitle(catalog.Get(model.id), model)});
  }
  WriteMeshSheet(tiles, sheet_options, out_path);
  return static_cast<int>(tiles.size());
}

// `catalog import DIR --class CLASS|auto`: the class map of a folder of meshes.
int ImportFolder(MeshFolderImportOptions options, const std::string& import_class) {
  if (import_class == "clutter") {
    options.clutter = true;
  } else if (import_class != "auto") {
    options.furniture_class = ParseFurnitureClass(import_class);
  }
  std::cout << FormatMeshImport(ImportMeshFolder(options), options.out);
  return 0;
}

// `catalog import`: needs no catalog.
struct ImportFlags {
  MeshFolderImportOptions options;
  std::string furniture_class = "auto";
};

CLI::App* AddImportSubcommand(CLI::App* app, ImportFlags* flags) {
  CLI::App* import = app->add_subcommand(
      "import", "Write a starter class map (version 2) for a folder of mesh files");
  import->add_option("dir", flags->options.dir, "Folder of meshes (searched recursively)")
      ->required();
  import
      ->add_option("--class",
                   flags->furniture_class,
                   EnumNameList<FurnitureClass>() +
                       ", clutter, or auto: each file's folder name (Chairs/, Tables/, ...)")
      ->capture_default_str();
  import->add_option("--out", flags->options.out, "Class map to write (.json)")->required();
  import->add_flag("--overwrite", flags->options.overwrite, "Replace an existing class map");
  return import;
}

// The varied tables and sideboards a sheet may draw besides the catalog's.
struct SheetVariety {
  int per_class = 0;
  ShapeSizes sizes = ShapeSizes::kCatalog;
};

void AddSheetVarietyFlags(CLI::App* sheet, SheetVariety* variety) {
  sheet->add_option("--shape-variety",
                    variety->per_class,
                    "Also draw this many varied tables and sideboards per class (what "
                    "train --vote-shape-variety mixes into the training rooms, seed 1)");
  AddEnumOption(sheet,
                "--shape-sizes",
                &variety->sizes,
                "Their sizes (train --vote-shape-sizes): the catalog's range, or real");
}

int DrawSheet(const Catalog& catalog,
              const SheetVariety& variety,
              const ListCatalogOptions& list_options,
              const MeshSheetOptions& sheet_options,
              const std::string& out_path) {
  Catalog drawn_catalog = catalog.Copy();
  if (variety.per_class != 0)
    drawn_catalog.AddModels(MakeShapeVariety(catalog, {}, variety.per_class, 1, variety.sizes),
                            "Shape variety",
                            "shape variety");
  const int drawn = DrawCatalogSheet(drawn_catalog, list_options, sheet_options, out_path);
  std::cout << "wrote " << out_path << " (" << drawn << " models)\n";
  return 0;
}

}  // namespace

int RunCatalog(int argc, char** argv) {
  CLI::App app{"List, show, export and draw CAD catalog entries", "workbench catalog"};
  app.require_subcommand(1);
  CatalogFlags catalog_flags;

  CLI::App* list = app.add_subcommand("list", "List catalog entries (classified ones by default)");
  AddCatalogFlags(list, &catalog_flags);
  ListCatalogOptions list_options;
  bool json = false;
  std::string class_name;
  list->add_flag("--all", list_options.all_entries, "Also list entries without a class");
  list->add_option(
      "--class", class_name, "Only this class (" + EnumNameList<FurnitureClass>() + ")");
  list->add_flag("--load",
                 list_options.load_models,
                 "Import every listed model: triangle counts, hashes, skipped models");
  list->add_flag("--json", json, "JSON instead of a table");

  CLI::App* show = app.add_subcommand("show", "Load one entry and describe its model");
  AddCatalogFlags(show, &catalog_flags);
  std::string entry_id;
  show->add_option("entry", entry_id, "Entry id, e.g. Scopia/chair3")->required();
  show->add_flag("--json", json, "JSON instead of text");

  CLI::App* export_command = app.add_subcommand("export", "Write one entry's normalised mesh");
  AddCatalogFlags(export_command, &catalog_flags);
  std::string out_path;
  export_command->add_option("entry", entry_id, "Entry id")->required();
  export_command->add_option("--out", out_path, "Output file: .ply, .obj, .stl or .glb")
      ->required();

  CLI::App* sheet = app.add_subcommand("sheet", "Draw entries as a PNG contact sheet");
  AddCatalogFlags(sheet, &catalog_flags);
  MeshSheetOptions sheet_options;
  sheet->add_flag("--all", list_options.all_entries, "Also draw entries without a class");
  sheet->add_option("--class", class_name, "Only this class");
  sheet->add_option("--out", out_path, "Output .png")->required();
  sheet->add_option("--tile", sheet_options.tile_px, "Tile size in pixels")->capture_default_str();
  sheet->add_option("--columns", sheet_options.columns, "Tiles per row")->capture_default_str();
  SheetVariety variety;
  AddSheetVarietyFlags(sheet, &variety);

  ImportFlags import_flags;
  CLI::App* import = AddImportSubcommand(&app, &import_flags);

  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);
  if (import->parsed()) return ImportFolder(import_flags.options, import_flags.furniture_class);
  if (!class_name.empty()) list_options.only_class = ParseFurnitureClass(class_name);
  const Catalog catalog = OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags));
  PrintWarnings(catalog.warnings());

  if (list->parsed()) {
    const CatalogListing listing = ListCatalog(catalog, list_options);
    PrintFailures(listing.failures);
    std::cout << (json ? CatalogListingToJson(listing) : FormatCatalogTable(listing));
    return 0;
  }
  if (show->parsed()) {
    const CatalogEntry& entry = catalog.Get(entry_id);
    std::cout << DescribeModel(entry, catalog.LoadModel(entry_id), json);
    return 0;
  }
  if (export_command->parsed()) {
    const CadModel model = catalog.LoadModel(entry_id);
    ExportMesh(model.mesh, out_path);
    std::cout << "wrote " << out_path << " (" << model.mesh.NumTriangles() << " triangles)\n";
    return 0;
  }
  return DrawSheet(catalog, variety, list_options, sheet_options, out_path);
}

}  // namespace furn
