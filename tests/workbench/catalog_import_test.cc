// `workbench catalog import`: a starter class map for a folder of meshes
// (issue 19): classes from folder names, units guessed from the height, the
// front of a chair from its back rest; the map opens and trains as written.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/geometry/mesh.h"
#include "core/util/error.h"
#include "scenes/catalog.h"
#include "scenes/mesh_io.h"
#include "tests/test_util.h"
#include "workbench/pipelines/catalog_tools.h"

namespace furn {
namespace {

using testing::ErrorOf;

// A chair facing +x (its back at -x), in centimetres, z up.
TriangleMesh ChairFacingPlusXInCm() {
  TriangleMesh chair = MakeBox(Eigen::Vector3f(0, 0, 40), Eigen::Vector3f(45, 45, 45));  // seat
  const TriangleMesh back = MakeBox(Eigen::Vector3f(0, 0, 45), Eigen::Vector3f(4, 45, 90));
  const TriangleMesh leg = MakeBox(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(4, 4, 40));
  for (const TriangleMesh* part : {&back, &leg}) {
    const int offset = static_cast<int>(chair.vertices.size());
    chair.vertices.insert(chair.vertices.end(), part->vertices.begin(), part->vertices.end());
    for (const Eigen::Vector3i& t : part->triangles)
      chair.triangles.push_back(t + Eigen::Vector3i::Constant(offset));
  }
  return chair;
}

TEST(CatalogImport, WritesAClassMapThatOpensAsWritten) {
  const std::string dir = testing::ScratchDir();
  std::filesystem::create_directories(dir + "/in/Chairs");
  std::filesystem::create_directories(dir + "/in/Tables");
  ExportMesh(ChairFacingPlusXInCm(), dir + "/in/Chairs/chair.ply");
  ExportMesh(MakeBox(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1.6f, 0.8f, 0.74f)),
             dir + "/in/Tables/desk.stl");
  testing::WriteText(dir + "/in/Tables/notes.txt", "not a mesh");
  MeshFolderImportOptions options;
  options.dir = dir + "/in";
  options.out = dir + "/maps/map.json";
  std::filesystem::create_directories(dir + "/maps");
  const MeshFolderImport import = ImportMeshFolder(options);
  ASSERT_EQ(import.meshes.size(), 2u);
  const ImportedMesh& chair = import.meshes[0];
  EXPECT_EQ(chair.id, "Chairs/chair");
  EXPECT_EQ(chair.class_name, "chair");
  EXPECT_EQ(chair.units, "cm");
  EXPECT_EQ(chair.front, "+x");
  EXPECT_EQ(chair.mesh, "../in/Chairs/chair.ply");  // relative to the map
  EXPECT_TRUE(chair.size_m.isApprox(Eigen::Vector3f(0.45f, 0.45f, 0.9f), 1e-4f));
  EXPECT_EQ(import.meshes[1].class_name, "table");
  EXPECT_EQ(import.meshes[1].units, "m");
  EXPECT_NE(FormatMeshImport(import, options.out).find("wrote " + options.out), std::string::npos);

  // The map as written: the chair turned to face -y, in metres.
  const Catalog catalog = OpenCatalog(options.out);
  ASSERT_EQ(catalog.Classified().size(), 2u);
  const Box3 box = BoundingBox(catalog.LoadModel("Chairs/chair").mesh);
  EXPECT_TRUE(box.Size().isApprox(Eigen::Vector3f(0.45f, 0.45f, 0.9f), 1e-4f));
  // The back (above the seat) now lies at +y, behind a piece facing -y.
  EXPECT_NEAR(box.max.y(), 0.225f, 1e-4f);
  const CadModel turned = catalog.LoadModel("Chairs/chair");
  float back_y = 0;
  int count = 0;
  for (const Eigen::Vector3f& v : turned.mesh.vertices) {
    if (v.z() > 0.6f) back_y += v.y(), ++count;
  }
  EXPECT_GT(back_y / count, 0.15f);

  // Nothing is overwritten without --overwrite; folder names must be classes.
  EXPECT_NE(ErrorOf([&] { ImportMeshFolder(options); }).find("give --overwrite"),
            std::string::npos);
  options.overwrite = true;
  std::filesystem::create_directories(dir + "/in/Stools");
  ExportMesh(MakeBox(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.3f, 0.3f, 0.5f)),
             dir + "/in/Stools/s.ply");
  EXPECT_NE(ErrorOf([&] { ImportMeshFolder(options); }).find("folder 'Stools' names no class"),
            std::string::npos);
  options.furniture_class = FurnitureClass::kChair;  // --class chair: every mesh a chair
  EXPECT_EQ(ImportMeshFolder(options).meshes.size(), 3u);
  options.dir = dir + "/maps/none";
  EXPECT_NE(ErrorOf([&] { ImportMeshFolder(options); }).find("no such folder"), std::string::npos);
  std::filesystem::create_directories(options.dir);
  EXPECT_NE(ErrorOf([&] { ImportMeshFolder(options); }).find("no mesh file"), std::string::npos);
}

}  // namespace
}  // namespace furn
