// Sweet Home 3D furniture catalogs (.sh3f), read straight from the zip.
//
// A .sh3f holds PluginFurnitureCatalog.properties (entries numbered N:
// id#N, name#N, category#N, model#N, width#N, depth#N, height#N in cm,
// elevation#N, modelRotation#N as 9 numbers row-major, doorOrWindow#N,
// creator#N) and the OBJ/MTL files the entries name. LoadModel does what
// Sweet Home 3D does: rotate the OBJ by modelRotation, scale its bounding box
// to exactly width x height x depth (y up there), then converts to the engine's
// frame: x = width, y = depth, z = height (up), front of the piece facing -y,
// base on z = 0, footprint centred on the origin.
//
//   Sh3fCatalog catalog("/usr/share/sweethome3d/furniture/Scopia.sh3f");
//   for (const Sh3fEntry& entry : catalog.entries()) {
//     CadModel model = catalog.LoadModel(entry);   // throws InputError on a
//     bad model
//   }
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/geometry/mesh.h"
#include "scenes/mesh_cache.h"

namespace furn {

class ZipArchive;

struct Sh3fEntry {
  std::string id;          // engine id "<catalog file stem>/<part of id#N after '#'>"
  std::string sh3d_id;     // id#N as written, e.g. "Scopia#chair3"
  int index = 0;           // N
  std::string name;        // name#N
  std::string category;    // category#N
  std::string creator;     // creator#N
  std::string model_path;  // model#N inside the zip, without the leading '/'
  float width_cm = 0;      // along x
  float depth_cm = 0;      // along y (Sweet Home 3D's z)
  float height_cm = 0;     // along z (Sweet Home 3D's y)
  float elevation_cm = 0;  // height of the base above the floor when placed
  Eigen::Matrix3f model_rotation = Eigen::Matrix3f::Identity();
  bool door_or_window = false;
};

class Sh3fCatalog {
 public:
  // Throws InputError when the file is missing, is not a zip, has no
  // PluginFurnitureCatalog.properties, or that file declares no models.
  // Entries with unusable keys (bad numbers, missing model) are skipped and
  // listed in problems().
  explicit Sh3fCatalog(const std::string& path);
  ~Sh3fCatalog();

  const std::string& path() const { return path_; }
  // File name without extension, e.g. "Scopia"; the prefix of every entry id.
  const std::string& stem() const { return stem_; }
  const std::vector<Sh3fEntry>& entries() const { return entries_; }
  const std::vector<std::string>& problems() const { return problems_; }
  const Sh3fEntry* Find(const std::string& id) const;

  // Loads and normalises one entry's model. Throws InputError naming the entry.
  CadModel LoadModel(const Sh3fEntry& entry) const;

 private:
  std::string path_;
  std::string stem_;
  std::unique_ptr<ZipArchive> zip_;
  MeshCache mesh_cache_ = MeshCache::FromEnvironment();
  std::vector<Sh3fEntry> entries_;
  std::vector<std::string> problems_;
};

// The Sweet Home 3D normalisation alone, on a mesh in the OBJ's own axes:
// rotate, scale the bounding box to the size in cm, convert to z up, place on
// the floor, centred. Throws InputError when the rotated model is flat along an
// axis that has to be scaled.
TriangleMesh NormalizeSweetHome3dMesh(TriangleMesh mesh,
                                      const Eigen::Matrix3f& model_rotation,
                                      float width_cm,
                                      float depth_cm,
                                      float height_cm,
                                      const std::string& where);

}  // namespace furn
