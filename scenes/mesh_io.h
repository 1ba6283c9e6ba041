// Loading and saving triangle meshes with assimp.
//
// A loaded model is converted to the engine's convention (metres, z up, base
// on z = 0, footprint centred on the origin). Files do not say which axis is
// up, so each format has a documented default that MeshLoadOptions overrides:
//   y up: obj, gltf, glb, dae, fbx, 3ds (assimp brings dae and 3ds to y up)
//   z up: ply, stl, off, vtk
// VTK legacy polydata (.vtk, the paper's own CAD models) is read by VTK, the
// library PCL reads it with (vtk_mesh.h); every other format by assimp.
// Export writes the inverse convention of the same format, so that
// LoadMeshFile(ExportMesh(mesh)) gives the mesh back.
//
//   CadModel chair = LoadMeshFile("chair.obj", MeshLoadOptions{.metres_per_unit
//   = 0.01}); ExportMesh(chair.mesh, "chair.ply");
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/geometry/mesh.h"

namespace furn {

class ZipArchive;

enum class UpAxis { kFormatDefault, kY, kZ };

struct MeshLoadOptions {
  // Metres per file unit (0.01 for a file in centimetres). Must be > 0.
  double metres_per_unit = 1.0;
  // Which file axis points up; kFormatDefault uses the table above.
  UpAxis up_axis = UpAxis::kFormatDefault;
  // Or the whole turn from the file's axes to the engine's (z up, the front
  // facing -y): set, it replaces up_axis (see AxesFromUpAndFront).
  std::optional<Eigen::Matrix3f> engine_from_file;
  // Scaled per axis after the turn to exactly this width x depth x height
  // (metres), as Sweet Home 3D scales its models; unset: units alone.
  std::optional<Eigen::Vector3f> size_m;

  bool Check() const;
};

// A signed axis of a file: "x", "+x", "-x", "y", ..., as a unit vector.
// Throws InputError naming `what` (e.g. "map.json: entry 'a/b' \"up\"").
Eigen::Vector3f ParseAxis(const std::string& text, const std::string& what);

// The turn from a file's axes to the engine's: `up` becomes +z and `front`
// (the direction the piece faces) becomes -y. Throws InputError when they
// are not perpendicular.
Eigen::Matrix3f AxesFromUpAndFront(const Eigen::Vector3f& up,
                                   const Eigen::Vector3f& front,
                                   const std::string& what);

// The front a file faces when only its up axis is given: -y, else +z, else
// -x, the first perpendicular to `up` (z up files face -y as the engine's
// models do; y up ones face +z, the glTF and Sweet Home 3D convention).
Eigen::Vector3f DefaultFront(const Eigen::Vector3f& up);

// Whether files of this extension (lower case, no dot) are read as y up
// when nothing says otherwise (the table above).
bool LoadsYUpByDefault(const std::string& extension);

// Metres per unit for "m", "cm", "mm", "in", "ft", or a positive number given
// as text. Throws InputError naming `what`.
double ParseUnits(const std::string& text, const std::string& what);

// Loads a model file, converts it, and checks it (faces present, all vertices
// finite). Throws InputError naming the file and the rule that failed.
CadModel LoadMeshFile(const std::string& path, const MeshLoadOptions& options = {});

// Raw triangles of a file inside a zip archive (materials and other files it
// references are read from the same archive), in the file's own axes and units.
TriangleMesh ImportMeshFromZip(const ZipArchive& archive, const std::string& entry);

// The file extensions assimp can import here, lower case, sorted.
std::vector<std::string> SupportedImportExtensions();

// Writes ply (binary), obj, stl (binary) or glb by extension, atomically.
// Throws InputError for another extension or when writing fails.
void ExportMesh(const TriangleMesh& mesh, const std::string& path);

// Rotation taking y-up coordinates (x, y, z) to z-up (x, -z, y): +90 deg about
// x.
Eigen::Matrix3f ZUpFromYUp();

// An MTL file's text without the statements before its first `newmtl`
// (they belong to no material; assimp 5.2 crashes on them). Every mesh import
// passes MTL files through it.
std::string SanitizeMtl(const std::string& bytes);

// Throws InputError naming `what` when a mesh in metres cannot be furniture:
// a non-finite box, beyond 1 km, or flat in two of its axes (all vertices
// equal, or units of 1e-300).
void CheckFurnitureExtent(const TriangleMesh& mesh, const std::string& what);

}  // namespace furn
