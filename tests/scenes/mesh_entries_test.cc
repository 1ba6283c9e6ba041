// Class map version 2: entries that are mesh files of their own (issue 19),
// in every supported format, with units, axes and sizes, and each kind of
// bad metadata refused with one line naming the entry and the rule.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/geometry/mesh.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "scenes/catalog.h"
#include "scenes/class_map.h"
#include "scenes/mesh_io.h"
#include "tests/test_util.h"

namespace furn {
namespace {

using testing::ErrorOf;

// A box of 0.8 (x) x 0.4 (y) x 0.9 (z) in the file's own axes and units.
constexpr char kBoxVtk[] = R"(# vtk DataFile Version 3.0
a box
ASCII
DATASET POLYDATA
POINTS 8 float
0 0 0  0.8 0 0  0.8 0.4 0  0 0.4 0
0 0 0.9  0.8 0 0.9  0.8 0.4 0.9  0 0.4 0.9
POLYGONS 6 30
4 0 3 2 1
4 4 5 6 7
4 0 1 5 4
4 1 2 6 5
4 2 3 7 6
4 3 0 4 7
)";

constexpr char kBoxOff[] = R"(OFF
8 6 0
0 0 0
0.8 0 0
0.8 0.4 0
0 0.4 0
0 0 0.9
0.8 0 0.9
0.8 0.4 0.9
0 0.4 0.9
4 0 3 2 1
4 4 5 6 7
4 0 1 5 4
4 1 2 6 5
4 2 3 7 6
4 3 0 4 7
)";

std::string MapV2(const std::string& entries) {
  return R"({"format": "furnidet-class-map", "version": 2, "entries": [)" + entries + "]}";
}

// Opens `entries` as a class map written into `dir` and loads `id`'s model.
CadModel LoadEntry(const std::string& dir, const std::string& entries, const std::string& id) {
  testing::WriteText(dir + "/map.json", MapV2(entries));
  return OpenCatalog(dir + "/map.json").LoadModel(id);
}

void ExpectSize(const CadModel& model, const Eigen::Vector3f& size, const std::string& what) {
  const Box3 box = BoundingBox(model.mesh);
  EXPECT_TRUE(box.Size().isApprox(size, 1e-4f)) << what << ": " << box.Size().transpose();
  EXPECT_NEAR(box.min.z(), 0, 1e-5) << what;                // base on the floor
  EXPECT_NEAR(box.min.x() + box.max.x(), 0, 1e-5) << what;  // footprint centred
}

TEST(MeshEntries, EveryFormatLoadsInMetresZUp) {
  const std::string dir = testing::ScratchDir();
  std::filesystem::create_directories(dir + "/models");
  testing::WriteText(dir + "/models/box.vtk", kBoxVtk);
  testing::WriteText(dir + "/models/box.off", kBoxOff);
  const CadModel box = LoadEntry(dir,
                                 R"({"id": "t/box", "class": "sideboard",
                                           "mesh": "models/box.vtk"})",
                                 "t/box");
  EXPECT_EQ(box.mesh.NumTriangles(), 12u);  // quads fanned into triangles
  ExpectSize(box, Eigen::Vector3f(0.8f, 0.4f, 0.9f), "vtk");
  // The same box written by our exporter (each format's own convention) and
  // read back through the class map.
  for (const char* extension : {"ply", "obj", "stl", "glb"}) {
    ExportMesh(box.mesh, dir + "/models/box." + extension);
    const CadModel again = LoadEntry(
        dir,
        std::string(R"({"id": "t/x", "class": "table", "mesh": "models/box.)") + extension + "\"}",
        "t/x");
    ExpectSize(again, Eigen::Vector3f(0.8f, 0.4f, 0.9f), extension);
    EXPECT_EQ(again.id, "t/x");
  }
  ExpectSize(LoadEntry(dir, R"({"id": "t/o", "class": "table", "mesh": "models/box.off"})", "t/o"),
             Eigen::Vector3f(0.8f, 0.4f, 0.9f),
             "off");
}

TEST(MeshEntries, UnitsAxesAndSizeAreApplied) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/box.vtk", kBoxVtk);
  auto load = [&](const std::string& fields) {
    return LoadEntry(
        dir, R"({"id": "t/b", "class": "chair", "mesh": "box.vtk", )" + fields + "}", "t/b");
  };
  ExpectSize(load(R"("units": "cm")"), Eigen::Vector3f(0.008f, 0.004f, 0.009f), "cm");
  ExpectSize(load(R"("units": "mm")"), Eigen::Vector3f(0.0008f, 0.0004f, 0.0009f), "mm");
  ExpectSize(load(R"("units": "in")"), 0.0254f * Eigen::Vector3f(0.8f, 0.4f, 0.9f), "in");
  ExpectSize(load(R"("units": 2)"), Eigen::Vector3f(1.6f, 0.8f, 1.8f), "number");
  // y up: the file's y (0.4) is the height; its +z (0.9) faces -y (depth).
  ExpectSize(load(R"("up": "y")"), Eigen::Vector3f(0.8f, 0.9f, 0.4f), "y up");
  // x up, facing +y: height 0.8, depth 0.4, width 0.9.
  ExpectSize(load(R"("up": "x", "front": "+y")"), Eigen::Vector3f(0.9f, 0.4f, 0.8f), "x up");
  // The front turns the piece: facing +x, its x extent becomes the depth.
  ExpectSize(load(R"("up": "z", "front": "x")"), Eigen::Vector3f(0.4f, 0.8f, 0.9f), "front x");
  ExpectSize(load(R"("size": [1.0, 0.5, 0.75])"), Eigen::Vector3f(1.0f, 0.5f, 0.75f), "size");
  // Facing +x: a point at the file's +x end lies on the engine's -y side.
  const CadModel turned = load(R"("up": "z", "front": "+x")");
  EXPECT_NEAR(BoundingBox(turned.mesh).min.y(), -0.4f, 1e-5);
}

TEST(MeshEntries, ClutterCatalogEntriesAndListing) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/box.vtk", kBoxVtk);
  testing::WriteText(dir + "/map.json",
                     MapV2(R"({"id": "t/box", "class": "sideboard", "mesh": "box.vtk",
                               "size": [1.2, 0.45, 0.8], "evaluation_only": true},
                              {"id": "t/lamp", "class": "clutter", "mesh": "box.vtk"})"));
  const Catalog catalog = OpenCatalog(dir + "/map.json");
  ASSERT_EQ(catalog.entries().size(), 2u);
  ASSERT_EQ(catalog.Classified().size(), 1u);
  const CatalogEntry& box = catalog.Get("t/box");
  EXPECT_EQ(box.furniture_class, FurnitureClass::kSideboard);
  EXPECT_TRUE(box.evaluation_only);
  EXPECT_TRUE(box.size_m.isApprox(Eigen::Vector3f(1.2f, 0.45f, 0.8f)));
  EXPECT_FALSE(catalog.Get("t/lamp").furniture_class.has_value());
  // Found from the class map's folder, wherever the process runs.
  EXPECT_EQ(std::filesystem::path(box.source), std::filesystem::path(dir) / "box.vtk");
}

TEST(MeshEntries, BadMetadataGivesOneLineNamingTheEntry) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/box.vtk", kBoxVtk);
  testing::WriteText(dir + "/empty.vtk",
                     "# vtk DataFile Version 3.0\nno faces\nASCII\nDATASET POLYDATA\n"
                     "POINTS 3 float\n0 0 0 1 0 0 0 1 0\n");
  testing::WriteText(dir + "/points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  testing::WriteText(dir + "/grid.vtk",
                     "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n");
  struct Case {
    std::string entry, expected;
  };
  const std::string path = dir + "/map.json";
  const Case cases[] = {
      {R"({"id": "t/a", "class": "chair", "mesh": "box.vtk", "units": "furlong"})",
       "entry 't/a' \"units\" 'furlong' is not a unit"},
      {R"({"id": "t/a", "class": "chair", "mesh": "box.vtk", "units": -1})",
       "\"units\" must be m, cm, mm, in, ft or a positive number"},
      // Issue 29: units of 1e300 made a mesh of size -inf, 1e-300 one of 0 x 0 x 0.
      {R"({"id": "t/a", "class": "chair", "mesh": "box.vtk", "units": 1e300})", "(1e-6..1000)"},
      {R"({"id": "t/a", "class": "chair", "mesh": "box.vtk", "units": "1e-300"})", "(1e-6..1000)"},
      {R"({"id": "t/a", "class": "chair", "mesh": "box.vtk", "up": "w"})",
       "entry 't/a' \"up\" 'w' is not an axis"},
      {R"({"id": "t/a", "class": "chair", "mesh": "box.vtk", "up": "z", "front": "-z"})",
       "entry 't/a': the front must be perpendicular to the up axis"},
      {R"({"id": "t/a", "class": "chair", "mesh": "box.vtk", "size": [1, 0, 1]})",
       "\"size\" must be [width, depth, height]"},
      {R"({"id": "t/a", "class": "chair", "mesh": "missing.obj"})",
       "entry 't/a' \"mesh\": " + dir + "/missing.obj does not exist"},
      {R"({"id": "t/a", "class": "chair", "units": "cm"})", "belongs to a \"mesh\" entry"},
      {R"({"id": "t/a", "class": "stool", "mesh": "box.vtk"})", "(or \"clutter\")"},
      {R"({"id": "t/a", "class": "chair", "mesh": "box.vtk", "colour": "red"})",
       "unknown field 'colour'"},
  };
  for (const Case& c : cases) {
    testing::WriteText(path, MapV2(c.entry));
    const std::string message = ErrorOf([&] { OpenCatalog(path); });
    EXPECT_NE(message.find(c.expected), std::string::npos) << c.entry << "\n" << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  // Version 1 has no mesh entries.
  testing::WriteText(path,
                     R"({"format": "furnidet-class-map", "version": 1, "catalogs": ["T.sh3f"],
                         "entries": [{"id": "T/a", "class": "chair", "mesh": "box.vtk"}]})");
  EXPECT_NE(ErrorOf([&] { OpenCatalog(path); }).find("needs class map version 2"),
            std::string::npos);
  // Meshes that open but hold no model: skipped with a one-line warning when
  // the catalog opens (as a bad .sh3f entry is).
  for (const auto& [file, expected] :
       std::vector<std::pair<std::string, std::string>>{{"empty.vtk", "mesh has no faces"},
                                                        {"points.obj", "mesh has no faces"},
                                                        {"grid.vtk", "not VTK polydata"}}) {
    testing::WriteText(path, MapV2(R"({"id": "t/a", "class": "chair", "mesh": ")" + file + "\"}"));
    const Catalog catalog = OpenCatalog(path);
    EXPECT_TRUE(catalog.entries().empty());
    ASSERT_EQ(catalog.warnings().size(), 1u);
    const std::string& message = catalog.warnings()[0];
    EXPECT_NE(message.find("skipped t/a: " + dir + "/" + file + ": " + expected), std::string::npos)
        << message;
  }
}

// The legacy VTK reader's own checks (scenes/vtk_mesh.cc): each damaged
// section is one line naming the file and the rule, before VTK reads a word;
// attributes after the cells are dropped and the triangles still load.
TEST(MeshEntries, DamagedVtkSectionsAreRefusedInOneLine) {
  const std::string dir = testing::ScratchDir();
  const std::string head = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n";
  const std::string points = "POINTS 3 float\n0 0 0 1 0 0 0 1 0\n";
  testing::WriteText(dir + "/attributes.vtk",
                     head + points + "POLYGONS 1 4\n3 0 1 2\nPOINT_DATA 3\nNORMALS n float\n");
  EXPECT_EQ(LoadMeshFile(dir + "/attributes.vtk").mesh.triangles.size(), 1u);
  struct Case {
    std::string body, expected;
  };
  const Case cases[] = {
      {"BINARY\nDATASET POLYDATA\n", "only ASCII VTK legacy files are read"},
      {"ASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 " + std::string(80, '1') + "\n",
       "a word of 80 characters (at most 64)"},
      {"ASCII\nDATASET POLYDATA\nPOINTS 99 float\n0 0 0\n",
       "the POINTS count 99 is more than the file can hold"},
      {"ASCII\nDATASET POLYDATA\nPOINTS 1 int\n0 0 0\n", "POINTS of type 'int'"},
      {"ASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 nan 0\n", "coordinate 'nan' is not a finite"},
      {"ASCII\nDATASET POLYDATA\nPOLYGONS 1 4\n3 0 1 2\n", "POLYGONS before POINTS"},
      {"ASCII\nDATASET POLYDATA\n" + points + "POLYGONS 1 4\n3 0 1 7\n",
       "a point index 7 is more than the file can hold"},
      {"ASCII\nDATASET POLYDATA\n" + points + "POLYGONS 5 4\n3 0 1 2\n",
       "POLYGONS declares 5 cells in 4 numbers"},
      {"ASCII\nDATASET POLYDATA\n" + points + "POLYGONS 2 4\n3 0 1 2\n",
       "POLYGONS runs past its declared size"},
      {"ASCII\nDATASET POLYDATA\n" + points + "POLYGONS 1 5\n3 0 1 2 0\n",
       "POLYGONS holds 5 numbers, its cells another count"},
      {"ASCII\nDATASET POLYDATA\n" + points + "POLYGONS 1 2\nOFFSETS vtktypeint64\n0 3\n",
       "the VTK 5 cell layout"},
      {"ASCII\nDATASET POLYDATA\n" + points + "CELLS 1 4\n3 0 1 2\n", "unknown section 'CELLS'"},
      {"ASCII\nDATASET POLYDATA\n" + points + points, "two POINTS sections"},
      {"ASCII\nDATASET POLYDATA\n" + points + "POLYGONS 1", "the file ends where a cell list size"},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/bad.vtk";
    testing::WriteText(path, "# vtk DataFile Version 3.0\nt\n" + c.body);
    const std::string error = ErrorOf([&] { LoadMeshFile(path); });
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find(c.expected), std::string::npos) << c.expected << " | " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace furn
