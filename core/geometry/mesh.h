// Triangle meshes in the world convention: metres, z up.
//
// A CadModel is a mesh normalised as every model the engine trains on: base on
// z = 0, footprint (x, y bounding box) centred on the origin, so the object
// reference point of SPEC.md §3 is the model-frame origin.
//
//   TriangleMesh mesh = ...;
//   PlaceOnFloorCentred(&mesh);
//   CadModel model{"Scopia/chair3", "Chair", "/path.sh3f!/chair3.obj",
//                  HashMesh(mesh), mesh};
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace furn {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;
  // Indices into `vertices`, counter-clockwise seen from outside.
  std::vector<Eigen::Vector3i> triangles;

  size_t NumTriangles() const { return triangles.size(); }
  bool Empty() const { return triangles.empty(); }
};

struct Box3 {
  Eigen::Vector3f min = Eigen::Vector3f::Zero();
  Eigen::Vector3f max = Eigen::Vector3f::Zero();
  Eigen::Vector3f Size() const { return max - min; }
  Eigen::Vector3f Center() const { return 0.5f * (min + max); }
};

// Axis-aligned bounding box of the vertices used by triangles. Throws
// InputError for a mesh without triangles.
Box3 BoundingBox(const TriangleMesh& mesh);

// Applies p -> linear * p + translation to every vertex. A linear part with a
// negative determinant (a mirror) also flips the winding so faces stay outward.
void TransformMesh(const Eigen::Matrix3f& linear,
                   const Eigen::Vector3f& translation,
                   TriangleMesh* mesh);

// Appends `part` to `mesh` (indices shifted).
void AppendMesh(const TriangleMesh& part, TriangleMesh* mesh);

// Translates the mesh so its bounding box has min z = 0 and its x, y centre at
// the origin.
void PlaceOnFloorCentred(TriangleMesh* mesh);

// The mesh simplified by vertex clustering on a grid of `cell_m` (> 0): the
// vertices of each cell merge into their mean, triangles whose corners merge
// vanish, and so do repeated triangles. Deterministic (vertices keep the order
// of their cells' first vertex). Thin parts narrower than a cell may collapse.
TriangleMesh SimplifyMesh(const TriangleMesh& mesh, float cell_m);

// Throws InputError naming `what` when the mesh has no triangles, a
// non-finite vertex, or a triangle index out of range.
void CheckMeshValid(const TriangleMesh& mesh, const std::string& what);

// Incremental XXH3-128 content hash, as 32 hex digits.
class ContentHasher {
 public:
  ContentHasher();
  ~ContentHasher();
  ContentHasher(const ContentHasher&) = delete;
  ContentHasher& operator=(const ContentHasher&) = delete;
  void Update(const void* data, size_t bytes);
  std::string HexDigest() const;

 private:
  void* state_;
};

// The first `digits` (1..32) hex digits of the text's XXH3-128 hash: a short
// name for what decides a file (a cache key, a fold's model).
std::string ShortHash(const std::string& text, size_t digits = 16);

// 32 hex digits (XXH3-128) over the vertex and triangle buffers: two meshes
// with the same geometry have the same hash on every machine.
std::string HashMesh(const TriangleMesh& mesh);

// Sum of triangle areas in square metres.
double SurfaceArea(const TriangleMesh& mesh);

// A furniture model ready for training, rendering and room composition.
struct CadModel {
  std::string id;            // unique, e.g. "Scopia/chair3"
  std::string name;          // human-readable, e.g. "Chair"
  std::string source_path;   // file, or "archive.sh3f!/inner/model.obj"
  std::string content_hash;  // HashMesh(mesh)
  TriangleMesh mesh;         // metres, z up, base on z = 0, footprint centred
};

// Primitives for procedural furniture and rooms. Faces point outward.
// Axis-aligned box between two corners.
TriangleMesh MakeBox(const Eigen::Vector3f& min_corner, const Eigen::Vector3f& max_corner);

// Vertical cylinder standing on `base_center`, closed at both ends.
TriangleMesh MakeCylinder(const Eigen::Vector3f& base_center,
                          float radius,
                          float height,
                          int segments);

}  // namespace furn
