// Test fixtures for the scenes layer: an asymmetric "marker" mesh whose pose
// can be checked after import, writers for every mesh format the tests cover
// (each in that format's own axis convention), and a zip writer for .sh3f.
#pragma once

#include <map>
#include <set>
#include <string>

#include "core/geometry/mesh.h"

namespace furn::testing {

// In the engine frame: a 0.4 x 0.6 x 0.5 m base with a post up to 1.0 m at
// its +x, +y corner. Size 0.4 x 0.6 x 1.0.
TriangleMesh MarkerMesh();

// Expects `mesh` to be MarkerMesh() scaled to `size`, base on z = 0, footprint
// centred, the post at +x, +y (so neither mirrored nor rotated).
void ExpectMarkerPose(const TriangleMesh& mesh, const Eigen::Vector3f& size, float tolerance);

// Coordinates in the file = file_from_engine * engine coordinates.
Eigen::Matrix3f YUpFromZUp();  // (x, y, z) -> (x, z, -y)

std::string ObjText(const TriangleMesh& mesh,
                    const Eigen::Matrix3f& file_from_engine,
                    const std::string& mtllib = "");
std::string PlyAsciiText(const TriangleMesh& mesh);
std::string StlAsciiText(const TriangleMesh& mesh);
std::string OffText(const TriangleMesh& mesh);
std::string GltfEmbeddedText(const TriangleMesh& mesh);  // y up, as glTF requires
std::string ColladaZUpText(const TriangleMesh& mesh);

// Writes a zip; entries named in `stored` are not compressed (so tests can
// corrupt their bytes in place).
void WriteZip(const std::string& path,
              const std::map<std::string, std::string>& files,
              const std::set<std::string>& stored = {});

}  // namespace furn::testing

namespace furn::testing {

// Writes `dir`/`file_name` (a .sh3f) with four entries:
//   <stem>/marker   MarkerMesh in y-up OBJ units of 1/37 m, with an MTL file,
//                   catalog size 40 x 60 x 100 cm;
//   <stem>/rotated  MarkerMesh authored z-up (x50) with modelRotation to y-up,
//                   catalog size 80 x 120 x 200 cm;
//   <stem>/missing  names an OBJ the zip does not hold (fails to load);
//   entry 4         has width "abc" (skipped when the catalog is read).
// Returns the path.
std::string WriteTestSh3f(const std::string& dir, const std::string& file_name);

}  // namespace furn::testing
