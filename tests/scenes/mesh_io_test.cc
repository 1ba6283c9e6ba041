#include "scenes/mesh_io.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include <filesystem>

#include "core/util/error.h"
#include "tests/scenes/fixtures.h"
#include "tests/test_util.h"

namespace furn {
namespace {

using testing::ErrorOf;

using testing::MarkerMesh;

const Eigen::Vector3f kMarkerSize(0.4f, 0.6f, 1.0f);

// Loads `text` written as `file_name` and returns the model.
CadModel LoadText(const std::string& file_name,
                  const std::string& text,
                  const MeshLoadOptions& options = {}) {
  const std::string path = testing::ScratchDir() + "/" + file_name;
  testing::WriteText(path, text);
  return LoadMeshFile(path, options);
}

TEST(MeshIo, ObjIsYUpByDefault) {
  const CadModel model =
      LoadText("marker.obj", testing::ObjText(MarkerMesh(), testing::YUpFromZUp()));
  testing::ExpectMarkerPose(model.mesh, kMarkerSize, 1e-5f);
  EXPECT_EQ(model.mesh.NumTriangles(), 24u);
  EXPECT_EQ(model.id, "marker");
  EXPECT_EQ(model.content_hash, HashMesh(model.mesh));
}

TEST(MeshIo, ObjInCentimetresScalesToMetres) {
  Eigen::Matrix3f to_cm = 100.0f * testing::YUpFromZUp();
  MeshLoadOptions options;
  options.metres_per_unit = 0.01;
  const CadModel model = LoadText("marker_cm.obj", testing::ObjText(MarkerMesh(), to_cm), options);
  testing::ExpectMarkerPose(model.mesh, kMarkerSize, 1e-4f);
}

TEST(MeshIo, UpAxisOverrideReadsZUpObj) {
  MeshLoadOptions options;
  options.up_axis = UpAxis::kZ;
  const CadModel model =
      LoadText("zup.obj", testing::ObjText(MarkerMesh(), Eigen::Matrix3f::Identity()), options);
  testing::ExpectMarkerPose(model.mesh, kMarkerSize, 1e-5f);
}

TEST(MeshIo, PlyIsZUp) {
  testing::ExpectMarkerPose(
      LoadText("marker.ply", testing::PlyAsciiText(MarkerMesh())).mesh, kMarkerSize, 1e-5f);
}

TEST(MeshIo, StlIsZUp) {
  testing::ExpectMarkerPose(
      LoadText("marker.stl", testing::StlAsciiText(MarkerMesh())).mesh, kMarkerSize, 1e-5f);
}

TEST(MeshIo, OffIsZUp) {
  testing::ExpectMarkerPose(
      LoadText("marker.off", testing::OffText(MarkerMesh())).mesh, kMarkerSize, 1e-5f);
}

TEST(MeshIo, GltfIsYUp) {
  testing::ExpectMarkerPose(
      LoadText("marker.gltf", testing::GltfEmbeddedText(MarkerMesh())).mesh, kMarkerSize, 1e-5f);
}

TEST(MeshIo, ColladaWithZUpAxisLoadsUpright) {
  testing::ExpectMarkerPose(
      LoadText("marker.dae", testing::ColladaZUpText(MarkerMesh())).mesh, kMarkerSize, 1e-5f);
}

TEST(MeshIo, ExportThenLoadGivesTheMeshBackInEveryFormat) {
  TriangleMesh mesh = MarkerMesh();
  PlaceOnFloorCentred(&mesh);
  const std::string dir = testing::ScratchDir();
  for (const std::string extension : {"ply", "obj", "stl", "glb"}) {
    SCOPED_TRACE(extension);
    const std::string path = dir + "/roundtrip." + extension;
    ExportMesh(mesh, path);
    const CadModel loaded = LoadMeshFile(path);
    testing::ExpectMarkerPose(loaded.mesh, kMarkerSize, 1e-5f);
    EXPECT_NEAR(SurfaceArea(loaded.mesh), SurfaceArea(mesh), 1e-4);
  }
}

TEST(MeshIo, ExportRejectsUnknownFormatAndLeavesNothing) {
  const std::string dir = testing::ScratchDir();
  EXPECT_NE(
      ErrorOf([&] { ExportMesh(MarkerMesh(), dir + "/x.xyz"); }).find("cannot export format 'xyz'"),
      std::string::npos);
  EXPECT_THROW(ExportMesh(MarkerMesh(), dir + "/missing/x.ply"), InputError);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

TEST(MeshIo, MissingFileIsNamed) {
  EXPECT_EQ(ErrorOf([] { LoadMeshFile("/nonexistent/chair.obj"); }),
            "/nonexistent/chair.obj: file does not exist");
}

TEST(MeshIo, UnknownFormatIsNamed) {
  const std::string message = ErrorOf([] { LoadText("chair.xyz", "whatever"); });
  EXPECT_NE(message.find("chair.xyz: unknown format 'xyz'"), std::string::npos) << message;
}

TEST(MeshIo, ObjWithoutFacesIsRejected) {
  const std::string message =
      ErrorOf([] { LoadText("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"); });
  EXPECT_NE(message.find("points.obj: mesh has no faces"), std::string::npos) << message;
}

TEST(MeshIo, ObjWithNanVerticesIsRejected) {
  const std::string message =
      ErrorOf([] { LoadText("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"); });
  EXPECT_NE(message.find("nan.obj: vertex 1 is not finite"), std::string::npos) << message;
}

TEST(MeshIo, GarbageInAKnownFormatIsRejected) {
  const std::string message = ErrorOf([] { LoadText("broken.ply", "ply\nformat nonsense\n"); });
  EXPECT_NE(message.find("broken.ply: "), std::string::npos) << message;
}

TEST(MeshIo, BadOptionsAreRejected) {
  MeshLoadOptions options;
  options.metres_per_unit = -1;
  EXPECT_THROW(LoadText("m.obj", testing::ObjText(MarkerMesh(), testing::YUpFromZUp()), options),
               InputError);
  EXPECT_GT(SupportedImportExtensions().size(), 20u);
}

// A face of 200,000 vertices took assimp 133 s to triangulate: refused at
// once, naming the file and line.
TEST(MeshIo, HugeFacesAreRefusedBeforeAssimp) {
  const std::string dir = testing::ScratchDir();
  std::string obj = "# a huge polygon\n";
  std::string face = "f";
  for (int i = 0; i < 5000; ++i) {
    obj += "v " + std::to_string(std::cos(i * 1e-3)) + " " + std::to_string(std::sin(i * 1e-3)) +
           " 0\n";
    face += " " + std::to_string(i + 1);
  }
  testing::WriteText(dir + "/huge.obj", obj + face + "\n");
  const auto start = std::chrono::steady_clock::now();
  const std::string error = testing::ErrorOf([&] { LoadMeshFile(dir + "/huge.obj", {}); });
  EXPECT_NE(error.find("huge.obj:5002: a face of 5000 vertices (at most 1024)"), std::string::npos)
      << error;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
}

}  // namespace
}  // namespace furn
