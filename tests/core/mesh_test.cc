#include "core/geometry/mesh.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/util/error.h"

namespace furn {
namespace {

TEST(Mesh, BoundingBoxOfBoxIsItsCorners) {
  const TriangleMesh box = MakeBox({-1, 2, 3}, {4, 5, 6.5f});
  const Box3 bounds = BoundingBox(box);
  EXPECT_TRUE(bounds.min.isApprox(Eigen::Vector3f(-1, 2, 3)));
  EXPECT_TRUE(bounds.max.isApprox(Eigen::Vector3f(4, 5, 6.5f)));
  EXPECT_EQ(box.NumTriangles(), 12u);
}

TEST(Mesh, BoxIsClosedWithOutwardFaces) {
  // Divergence theorem: sum over faces of (centroid . normal) * area / 3 =
  // volume.
  const TriangleMesh box = MakeBox({0, 0, 0}, {1, 2, 3});
  double volume = 0;
  for (const Eigen::Vector3i& t : box.triangles) {
    const Eigen::Vector3d a = box.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = box.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = box.vertices[t[2]].cast<double>();
    volume += a.dot(b.cross(c)) / 6.0;
  }
  EXPECT_NEAR(volume, 6.0, 1e-6);
  EXPECT_NEAR(SurfaceArea(box), 2 * (2 + 3 + 6), 1e-5);
}

TEST(Mesh, CylinderVolumeAndAreaApproachAnalyticValues) {
  const TriangleMesh cylinder = MakeCylinder({0, 0, 0}, 0.5f, 2.0f, 256);
  double volume = 0;
  for (const Eigen::Vector3i& t : cylinder.triangles) {
    volume +=
        cylinder.vertices[t[0]].cast<double>().dot(
            cylinder.vertices[t[1]].cast<double>().cross(cylinder.vertices[t[2]].cast<double>())) /
        6.0;
  }
  EXPECT_NEAR(volume, M_PI * 0.25 * 2.0, 1e-3);
  EXPECT_NEAR(SurfaceArea(cylinder), 2 * M_PI * 0.25 + 2 * M_PI * 0.5 * 2.0, 2e-3);
  EXPECT_THROW(MakeCylinder({0, 0, 0}, 1, 1, 2), InputError);
}

TEST(Mesh, PlaceOnFloorCentredPutsBaseAtZeroAndFootprintAtOrigin) {
  TriangleMesh mesh = MakeBox({3, -7, 2}, {5, -6, 4});
  PlaceOnFloorCentred(&mesh);
  const Box3 bounds = BoundingBox(mesh);
  EXPECT_NEAR(bounds.min.z(), 0, 1e-6);
  EXPECT_NEAR(bounds.max.z(), 2, 1e-6);
  EXPECT_NEAR(bounds.Center().x(), 0, 1e-6);
  EXPECT_NEAR(bounds.Center().y(), 0, 1e-6);
}

TEST(Mesh, MirrorTransformKeepsFacesOutward) {
  TriangleMesh mesh = MakeBox({0, 0, 0}, {1, 1, 1});
  Eigen::Matrix3f mirror = Eigen::Vector3f(-1, 1, 1).asDiagonal();
  TransformMesh(mirror, Eigen::Vector3f::Zero(), &mesh);
  double volume = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    volume += mesh.vertices[t[0]].cast<double>().dot(
                  mesh.vertices[t[1]].cast<double>().cross(mesh.vertices[t[2]].cast<double>())) /
              6.0;
  }
  EXPECT_NEAR(volume, 1.0, 1e-6);  // negative if the winding were not flipped
}

TEST(Mesh, AppendShiftsIndices) {
  TriangleMesh mesh = MakeBox({0, 0, 0}, {1, 1, 1});
  AppendMesh(MakeBox({2, 0, 0}, {3, 1, 1}), &mesh);
  EXPECT_EQ(mesh.vertices.size(), 16u);
  EXPECT_EQ(mesh.triangles.back().minCoeff() >= 8, true);
  EXPECT_NEAR(BoundingBox(mesh).max.x(), 3, 1e-6);
}

TEST(Mesh, HashIsStableAndSensitive) {
  const TriangleMesh a = MakeBox({0, 0, 0}, {1, 1, 1});
  TriangleMesh b = a;
  EXPECT_EQ(HashMesh(a), HashMesh(b));
  EXPECT_EQ(HashMesh(a).size(), 32u);
  b.vertices[3].x() += 1e-6f;
  EXPECT_NE(HashMesh(a), HashMesh(b));
}

TEST(Mesh, ShortHashIsAPrefixOfTheTextsHash) {
  const std::string a = ShortHash("fold 1 of 3"), b = ShortHash("fold 2 of 3");
  EXPECT_EQ(a.size(), 16u);
  EXPECT_NE(a, b);
  EXPECT_EQ(ShortHash("fold 1 of 3", 12), a.substr(0, 12));
  EXPECT_EQ(ShortHash("fold 1 of 3", 32).substr(0, 16), a);
  EXPECT_THROW(ShortHash("x", 0), InputError);
  EXPECT_THROW(ShortHash("x", 33), InputError);
}

TEST(Mesh, CheckRejectsEmptyNonFiniteAndOutOfRange) {
  TriangleMesh mesh = MakeBox({0, 0, 0}, {1, 1, 1});
  EXPECT_NO_THROW(CheckMeshValid(mesh, "box"));
  TriangleMesh empty;
  try {
    CheckMeshValid(empty, "empty.obj");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("empty.obj: mesh has no faces"), std::string::npos);
  }
  TriangleMesh with_nan = mesh;
  with_nan.vertices[2].y() = std::nanf("");
  EXPECT_THROW(CheckMeshValid(with_nan, "nan"), InputError);
  TriangleMesh bad_index = mesh;
  bad_index.triangles[0][1] = 99;
  EXPECT_THROW(CheckMeshValid(bad_index, "index"), InputError);
  EXPECT_THROW(BoundingBox(empty), InputError);
}

TEST(Mesh, SimplifyMergesCellsDropsDegenerateTrianglesAndKeepsTheShape) {
  // A finely tessellated 1 m square (2 x 100 x 100 triangles).
  TriangleMesh grid;
  for (int i = 0; i <= 100; ++i) {
    for (int j = 0; j <= 100; ++j) grid.vertices.emplace_back(i * 0.01f, j * 0.01f, 0.f);
  }
  for (int i = 0; i < 100; ++i) {
    for (int j = 0; j < 100; ++j) {
      const int a = i * 101 + j;
      grid.triangles.emplace_back(a, a + 101, a + 102);
      grid.triangles.emplace_back(a, a + 102, a + 1);
    }
  }
  const TriangleMesh simple = SimplifyMesh(grid, 0.05f);
  EXPECT_LT(simple.NumTriangles(), grid.NumTriangles() / 10);
  EXPECT_GT(simple.NumTriangles(), 100u);
  EXPECT_NO_THROW(CheckMeshValid(simple, "simplified"));
  EXPECT_NEAR(SurfaceArea(simple), 1.0, 0.1);
  EXPECT_EQ(SimplifyMesh(grid, 0.05f).vertices, simple.vertices);  // deterministic
  // A box bigger than the cell keeps its 12 triangles; one smaller vanishes.
  EXPECT_EQ(SimplifyMesh(MakeBox({0, 0, 0}, {1, 1, 1}), 0.3f).NumTriangles(), 12u);
  EXPECT_TRUE(SimplifyMesh(MakeBox({0.01f, 0.01f, 0.01f}, {0.02f, 0.02f, 0.02f}), 0.3f).Empty());
  EXPECT_THROW(SimplifyMesh(grid, 0.f), InputError);
}

}  // namespace
}  // namespace furn
