// Both renderers: exact depth on planes, ids and normals, agreement with each
// other on a furnished room, and clear errors for bad requests.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "core/util/error.h"
#include "renderers/depth_renderer.h"
#include "renderers/embree_caster.h"
#include "renderers/kinect_noise.h"
#include "tests/renderers/render_fixtures.h"

namespace furn {
namespace {

// `object` with each triangle split into four, `times` times: Embree puts
// meshes of up to 64 triangles into a scene's top level and instances larger
// ones, and both paths need testing.
SceneObject Subdivided(SceneObject object, int times) {
  TriangleMesh mesh = *object.mesh;
  for (int pass = 0; pass < times; ++pass) {
    std::vector<Eigen::Vector3i> triangles;
    for (const Eigen::Vector3i& t : mesh.triangles) {
      int middle[3];
      for (int e = 0; e < 3; ++e) {
        middle[e] = static_cast<int>(mesh.vertices.size());
        mesh.vertices.push_back(0.5f * (mesh.vertices[t[e]] + mesh.vertices[t[(e + 1) % 3]]));
      }
      triangles.push_back({t[0], middle[0], middle[2]});
      triangles.push_back({middle[0], t[1], middle[1]});
      triangles.push_back({middle[2], middle[1], t[2]});
      triangles.push_back({middle[0], middle[1], middle[2]});
    }
    mesh.triangles = std::move(triangles);
  }
  object.mesh = std::make_shared<const TriangleMesh>(std::move(mesh));
  return object;
}

class RendererTest : public ::testing::TestWithParam<RendererKind> {
 protected:
  std::unique_ptr<DepthRenderer> renderer_ = MakeRenderer(GetParam());
  CameraIntrinsics camera_ = CameraIntrinsics::KinectV1();
};

TEST_P(RendererTest, FrontoParallelPlaneRendersAtItsDistanceEverywhere) {
  Scene scene;
  scene.objects.push_back(testing::WallAt(2.0));
  const DepthFrame frame =
      renderer_->Render(scene, camera_, testing::CameraAtOriginLookingAlongY());
  ASSERT_EQ(frame.NumValid(), 307200u);
  float worst = 0;
  for (float z : frame.depth) worst = std::max(worst, std::abs(z - 2.0f));
  EXPECT_LT(worst, 1e-4f) << "worst depth error " << worst << " m";
  EXPECT_EQ(frame.IdAt(0, 0), kWallId);
  EXPECT_TRUE(frame.normals[frame.Index(320, 240)].isApprox(Eigen::Vector3f(0, 0, -1), 1e-4f));
}

TEST_P(RendererTest, TiltedPlaneMatchesAnalyticDepth) {
  // The wall plane y = 2 seen by a camera yawed by 25 degrees and pitched
  // by 10.
  Scene scene;
  scene.objects.push_back(testing::WallAt(2.0));
  const double yaw = 25 * M_PI / 180, pitch = 10 * M_PI / 180;
  const Eigen::Vector3d forward(
      std::sin(yaw) * std::cos(pitch), std::cos(yaw) * std::cos(pitch), -std::sin(pitch));
  const Eigen::Isometry3d world_from_camera = LookAlong(Eigen::Vector3d(0.1, -0.2, 1.0), forward);
  const DepthFrame frame = renderer_->Render(scene, camera_, world_from_camera);
  const Eigen::Vector3d normal_in_camera =
      world_from_camera.linear().transpose() * Eigen::Vector3d::UnitY();
  const double offset = 2.0 - world_from_camera.translation().y();  // plane: n . X_camera = offset
  double worst = 0;
  for (int v = 0; v < camera_.height; v += 3) {
    for (int u = 0; u < camera_.width; u += 3) {
      const double expected =
          offset / normal_in_camera.dot(camera_.RayThroughPixel(u, v).cast<double>());
      worst = std::max(worst, std::abs(frame.DepthAt(u, v) - expected));
    }
  }
  EXPECT_LT(worst, 1e-4) << "worst depth error " << worst << " m";
}

TEST_P(RendererTest, IdsAndNormalsOfABoxInFrontOfAWall) {
  Scene scene;
  scene.objects.push_back(testing::WallAt(3.0));
  scene.objects.push_back(testing::BoxAt(1.5, -0.2, 0.2, -0.2, 0.2, 42));
  const DepthFrame frame =
      renderer_->Render(scene, camera_, testing::CameraAtOriginLookingAlongY());
  EXPECT_EQ(frame.IdAt(320, 240), 42);
  EXPECT_NEAR(frame.DepthAt(320, 240), 1.5f, 1e-4f);
  EXPECT_EQ(frame.IdAt(10, 10), kWallId);
  EXPECT_NEAR(frame.DepthAt(10, 10), 3.0f, 1e-4f);
  // The box spans x = +-0.2 m at 1.5 m: 580 * 0.2 / 1.5 = 77.3 px each side of
  // the centre.
  EXPECT_EQ(frame.IdAt(319 + 76, 240), 42);
  EXPECT_EQ(frame.IdAt(319 + 79, 240), kWallId);
  EXPECT_EQ(frame.IdAt(320 - 76, 240), 42);
  EXPECT_EQ(frame.IdAt(320 - 79, 240), kWallId);
}

// A rotated box, small (Embree: world-space triangles in the top level) and
// subdivided (an instance, whose hit normals come in object space).
TEST_P(RendererTest, DepthAndNormalOfARotatedObject) {
  for (int subdivisions : {0, 2}) {
    SCOPED_TRACE(subdivisions);
    Scene scene;
    scene.objects.push_back(testing::WallAt(4.0));
    SceneObject box = Subdivided(testing::BoxAt(-0.15, -0.3, 0.3, -0.3, 0.3, 42),
                                 subdivisions);  // centred on the origin
    const double yaw = 30 * M_PI / 180;
    box.world_from_object =
        Eigen::Translation3d(0, 2, 0) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
    scene.objects.push_back(box);
    const Eigen::Isometry3d world_from_camera = testing::CameraAtOriginLookingAlongY();
    const DepthFrame frame = renderer_->Render(scene, camera_, world_from_camera);
    // The front face: normal R (0, -1, 0), through the pose of (0, -0.15, 0).
    const Eigen::Vector3d normal = box.world_from_object.linear() * -Eigen::Vector3d::UnitY();
    const Eigen::Vector3d on_face = box.world_from_object * Eigen::Vector3d(0, -0.15, 0);
    const Eigen::Vector3d ray =
        world_from_camera.linear() * camera_.RayThroughPixel(320, 240).cast<double>();
    const double depth = normal.dot(on_face - world_from_camera.translation()) / normal.dot(ray);
    ASSERT_EQ(frame.IdAt(320, 240), 42);
    EXPECT_NEAR(frame.DepthAt(320, 240), depth, 1e-4);
    const Eigen::Vector3f expected =
        (world_from_camera.linear().transpose() * normal).cast<float>();
    EXPECT_TRUE(frame.normals[frame.Index(320, 240)].isApprox(expected, 1e-4f))
        << frame.normals[frame.Index(320, 240)].transpose() << " vs " << expected.transpose();
  }
}

// One mesh placed twice (as the room composer does with a set of chairs).
TEST_P(RendererTest, OneMeshPlacedTwiceShowsBothPlacements) {
  Scene scene;
  scene.objects.push_back(testing::WallAt(4.0));
  SceneObject left = Subdivided(testing::BoxAt(0, -0.2, 0.2, -0.2, 0.2, 42), 2);
  SceneObject right = left;  // shares the mesh
  left.world_from_object = Eigen::Translation3d(-0.5, 2, 0);
  right.world_from_object = Eigen::Translation3d(0.5, 2.5, 0);
  right.instance_id = 43;
  scene.objects.push_back(left);
  scene.objects.push_back(right);
  const Eigen::Isometry3d world_from_camera = testing::CameraAtOriginLookingAlongY();
  const DepthFrame frame = renderer_->Render(scene, camera_, world_from_camera);
  const Eigen::Vector2d left_pixel =
      camera_.Project(world_from_camera.inverse() * Eigen::Vector3d(-0.5, 2.0, 0));
  const Eigen::Vector2d right_pixel =
      camera_.Project(world_from_camera.inverse() * Eigen::Vector3d(0.5, 2.5, 0));
  EXPECT_EQ(frame.IdAt(left_pixel.x(), left_pixel.y()), 42);
  EXPECT_NEAR(frame.DepthAt(left_pixel.x(), left_pixel.y()), 2.0f, 1e-4f);
  EXPECT_EQ(frame.IdAt(right_pixel.x(), right_pixel.y()), 43);
  EXPECT_NEAR(frame.DepthAt(right_pixel.x(), right_pixel.y()), 2.5f, 1e-4f);
}

TEST_P(RendererTest, EmptySceneIsRejected) {
  const Scene empty;
  EXPECT_THROW(renderer_->Render(empty, camera_, testing::CameraAtOriginLookingAlongY()),
               InputError);
}

TEST_P(RendererTest, BadIntrinsicsAreRejected) {
  Scene scene;
  scene.objects.push_back(testing::WallAt(2.0));
  for (CameraIntrinsics bad : {CameraIntrinsics{0, 480},
                               CameraIntrinsics{640, -480},
                               CameraIntrinsics{640, 480, -580.0},
                               CameraIntrinsics{640, 480, 580, 0.0},
                               CameraIntrinsics{100000, 480}}) {
    EXPECT_THROW(renderer_->Render(scene, bad, testing::CameraAtOriginLookingAlongY()), InputError)
        << bad.ToString();
  }
}

TEST_P(RendererTest, CameraInsideGeometryIsRejected) {
  Scene scene;
  scene.objects.push_back(testing::WallAt(2.0));
  scene.objects.push_back(testing::BoxAt(-0.1, -0.5, 0.5, -0.5, 0.5, 11));  // encloses the origin
  try {
    renderer_->Render(scene, camera_, testing::CameraAtOriginLookingAlongY());
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("is inside scene object 1 (id 11)"), std::string::npos)
        << error.what();
  }
}

TEST_P(RendererTest, AbsurdSizesAreRejected) {
  Scene scene;
  scene.objects.push_back({std::make_shared<TriangleMesh>(MakeBox({-1e6f, 5, -1}, {1e6f, 6, 1})),
                           Eigen::Isometry3d::Identity(),
                           3});
  EXPECT_THROW(renderer_->Render(scene, camera_, testing::CameraAtOriginLookingAlongY()),
               InputError);
  Scene fine;
  fine.objects.push_back(testing::WallAt(2.0));
  Eigen::Isometry3d far_away = testing::CameraAtOriginLookingAlongY();
  far_away.translation().x() = 1e7;
  EXPECT_THROW(renderer_->Render(fine, camera_, far_away), InputError);
}

TEST_P(RendererTest, NormalsCanBeSwitchedOffWithoutChangingDepthOrIds) {
  const Scene scene = testing::FurnishedRoom(2);
  const DepthFrame with = renderer_->Render(scene, camera_, testing::FurnishedRoomCamera());
  renderer_->set_compute_normals(false);
  const DepthFrame without = renderer_->Render(scene, camera_, testing::FurnishedRoomCamera());
  EXPECT_TRUE(without.normals.empty());
  EXPECT_EQ(with.depth, without.depth);
  EXPECT_EQ(with.instance_ids, without.instance_ids);
  EXPECT_THROW(ApplyKinectNoise(without, camera_, KinectNoiseOptions{}, 1), InputError);
}

INSTANTIATE_TEST_SUITE_P(Renderers,
                         RendererTest,
                         ::testing::Values(RendererKind::kOsMesa, RendererKind::kEmbree),
                         [](const auto& info) {
                           return std::string(info.param == RendererKind::kOsMesa ? "OsMesa"
                                                                                  : "Embree");
                         });

TEST(RendererCrossCheck, OsMesaAndEmbreeAgreeOnAFurnishedRoom) {
  const Scene scene = testing::FurnishedRoom(3);
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const Eigen::Isometry3d world_from_camera = testing::FurnishedRoomCamera();
  const DepthFrame raster =
      MakeRenderer(RendererKind::kOsMesa)->Render(scene, camera, world_from_camera);
  const DepthFrame rays =
      MakeRenderer(RendererKind::kEmbree)->Render(scene, camera, world_from_camera);
  size_t both = 0, depth_agree = 0, id_agree = 0, objects_seen = 0;
  for (size_t i = 0; i < raster.depth.size(); ++i) {
    if (raster.depth[i] <= 0 || rays.depth[i] <= 0) continue;
    ++both;
    depth_agree += std::abs(raster.depth[i] - rays.depth[i]) < 0.001f;
    id_agree += raster.instance_ids[i] == rays.instance_ids[i];
    objects_seen += raster.instance_ids[i] >= kFirstObjectId;
  }
  ASSERT_GT(both, 300000u);
  EXPECT_GT(objects_seen, 30000u) << "the furniture should fill a good part of the view";
  EXPECT_GE(static_cast<double>(depth_agree) / both, 0.995) << depth_agree << " of " << both;
  EXPECT_GE(static_cast<double>(id_agree) / both, 0.995) << id_agree << " of " << both;
}

// Embree keeps one acceleration structure per live mesh for the process. A
// mesh built where a freed one was must get its own, not the stale one.
TEST(EmbreeMeshCache, MeshAtTheAddressOfAFreedOneIsRebuilt) {
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const Eigen::Isometry3d world_from_camera = testing::CameraAtOriginLookingAlongY();
  // Both meshes live in this storage, one after the other: the same address.
  alignas(TriangleMesh) unsigned char storage[sizeof(TriangleMesh)];
  auto render_box_at = [&](double front) {
    SceneObject box = testing::BoxAt(front, -0.5, 0.5, -0.5, 0.5, 42);
    box.mesh = std::shared_ptr<const TriangleMesh>(
        new (storage) TriangleMesh(*Subdivided(box, 2).mesh),
        [](const TriangleMesh* mesh) { mesh->~TriangleMesh(); });
    Scene scene;
    scene.objects.push_back(box);
    EmbreeCaster caster;
    return caster.Render(scene, camera, world_from_camera).DepthAt(320, 240);
  };
  EXPECT_NEAR(render_box_at(1.0), 1.0f, 1e-4f);
  EXPECT_NEAR(render_box_at(2.0), 2.0f, 1e-4f);
}

// CoverageIn (an object's amodal mask) casts occlusion rays in packets of
// 16, the last one partly filled. Every region size from 1 to 40 pixels wide
// leaves a different number of lanes unused; under FURN_EMBREE_CONFIG=isa=avx2
// (this test's [avx2] variant) Embree's 8-wide kernels read those lanes too.
TEST(EmbreeCoverage, MasksOfEveryRegionWidthMatchTheRenderedIds) {
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const Eigen::Isometry3d world_from_camera = testing::CameraAtOriginLookingAlongY();
  constexpr uint16_t kBoxId = 42;
  Scene scene;
  scene.objects.push_back(Subdivided(testing::BoxAt(2.0, -0.3, 0.3, -0.2, 0.2, kBoxId), 2));
  EmbreeCaster caster;
  const DepthFrame frame = caster.Render(scene, camera, world_from_camera);
  for (int width = 1; width <= 40; ++width) {
    // A band across the box's left edge, so some rays hit and some miss.
    const int u0 = 263 - width / 2, v0 = 230;
    const std::array<int, 4> region = {u0, v0, u0 + width - 1, v0 + 2};
    int64_t expected = 0;
    for (int v = region[1]; v <= region[3]; ++v) {
      for (int u = region[0]; u <= region[2]; ++u)
        expected += frame.instance_ids[frame.Index(u, v)] == kBoxId;
    }
    const EmbreeCaster::Coverage coverage =
        caster.CoverageIn(scene, camera, world_from_camera, region);
    EXPECT_EQ(coverage.pixels, expected) << "region width " << width;
  }
  // A region beyond the image is clipped to it.
  EXPECT_EQ(caster.CoverageIn(scene, camera, world_from_camera, {-50, -50, 700, 600}).pixels,
            std::count(frame.instance_ids.begin(), frame.instance_ids.end(), kBoxId));
}

TEST(RendererKinds, NamesParse) {
  EXPECT_EQ(ParseRendererKind("osmesa"), RendererKind::kOsMesa);
  EXPECT_EQ(ParseRendererKind("embree"), RendererKind::kEmbree);
  EXPECT_THROW(ParseRendererKind("vulkan"), InputError);
}

TEST(InsideMesh, ParityTestOnABox) {
  const TriangleMesh box = MakeBox({0, 0, 0}, {1, 2, 3});
  EXPECT_TRUE(IsInsideMesh(box, {0.5, 1, 1.5}));
  EXPECT_TRUE(IsInsideMesh(box, {0.01, 0.01, 0.01}));
  EXPECT_FALSE(IsInsideMesh(box, {1.5, 1, 1.5}));
  EXPECT_FALSE(IsInsideMesh(box, {-0.01, 1, 1}));
}

}  // namespace
}  // namespace furn
