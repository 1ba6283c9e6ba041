// Pictures of meshes for people: a shaded orthographic three-quarter view of
// each model (front, which faces -y, turned towards the viewer), tiled into a
// contact sheet with a title and a subtitle under each tile. Used to check a
// class map by eye and in reports.
//
//   std::vector<SheetTile> tiles = {{&chair.mesh, "Scopia/chair3", "chair
//   0.52x0.58x0.86 m"}}; WriteMeshSheet(tiles, MeshSheetOptions{},
//   "catalog.png");
#pragma once

#include <string>
#include <vector>

#include "core/geometry/mesh.h"

namespace furn {

struct SheetTile {
  const TriangleMesh* mesh = nullptr;
  std::string title;
  std::string subtitle;
};

struct MeshSheetOptions {
  int tile_px = 240;          // side of each tile's picture, pixels (32..2048)
  int columns = 6;            // tiles per row (>= 1)
  double azimuth_deg = -35;   // view direction turned from the front, degrees
  double elevation_deg = 25;  // view direction above the horizon, degrees

  bool Check() const;
};

// Renders the tiles and writes a PNG atomically. Throws InputError for bad
// options, an empty tile list, or a path that cannot be written.
void WriteMeshSheet(const std::vector<SheetTile>& tiles,
                    const MeshSheetOptions& options,
                    const std::string& png_path);

}  // namespace furn
