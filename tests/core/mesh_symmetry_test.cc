// Issue 73: the symmetries BOP's models_info.json carries, found on meshes
// whose symmetry is known by construction.
#include "core/geometry/mesh_symmetry.h"

#include <gtest/gtest.h>

namespace furn {
namespace {

TEST(MeshSymmetry, RectangleTwoSquareFourRoundContinuousLShapeNone) {
  const TriangleMesh rectangle = MakeBox({-0.6f, -0.4f, 0}, {0.6f, 0.4f, 0.75f});
  MeshSymmetry s = FindVerticalSymmetry(rectangle, {0, 0, 0.375f});
  EXPECT_FALSE(s.continuous);
  EXPECT_EQ(s.order, 2);

  const TriangleMesh square = MakeBox({-0.4f, -0.4f, 0}, {0.4f, 0.4f, 0.75f});
  s = FindVerticalSymmetry(square, {0, 0, 0.375f});
  EXPECT_FALSE(s.continuous);
  EXPECT_EQ(s.order, 4);

  const TriangleMesh round = MakeCylinder({0, 0, 0}, 0.5f, 0.75f, 96);
  s = FindVerticalSymmetry(round, {0, 0, 0.375f});
  EXPECT_TRUE(s.continuous);

  TriangleMesh chair = MakeBox({-0.25f, -0.25f, 0.4f}, {0.25f, 0.25f, 0.45f});  // seat
  AppendMesh(MakeBox({-0.25f, 0.2f, 0.45f}, {0.25f, 0.25f, 0.9f}), &chair);     // back
  s = FindVerticalSymmetry(chair, {0, 0, 0.45f});
  EXPECT_FALSE(s.continuous);
  EXPECT_EQ(s.order, 1);

  // The axis matters: the rectangle turned about a point off its centre is
  // not itself.
  s = FindVerticalSymmetry(rectangle, {0.3f, 0, 0.375f});
  EXPECT_EQ(s.order, 1);
  EXPECT_FALSE(s.continuous);
}

TEST(MeshSymmetry, AMeshWithoutAreaIsRefused) {
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.triangles = {{0, 1, 2}};
  EXPECT_THROW(FindVerticalSymmetry(flat, {0, 0, 0}), InputError);
}

}  // namespace
}  // namespace furn
