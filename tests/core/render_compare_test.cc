// Render-and-compare: intrinsics of organised clouds, what a scan says of a point, and the posed
// mesh cast against the depth (Embree).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/geometry/mesh.h"
#include "core/geometry/render_compare.h"
#include "core/util/error.h"
#include "tests/test_util.h"

namespace furn {
namespace {

// A 640x480 pinhole image (Kinect v1 intrinsics) of a wall at depth `z`.
std::vector<Eigen::Vector3f> Wall(float z, const PinholeIntrinsics& k) {
  std::vector<Eigen::Vector3f> points;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      points.emplace_back(
          static_cast<float>((u - k.cx) / k.fx * z), static_cast<float>((v - k.cy) / k.fy * z), z);
    }
  }
  return points;
}

TEST(RenderCompare, IntrinsicsOfAnOrganisedCloudAreRecovered) {
  const PinholeIntrinsics kinect{525, 525, 319.5, 239.5};
  std::vector<Eigen::Vector3f> points = Wall(2.0f, kinect);
  for (size_t i = 0; i < points.size(); i += 7) points[i] = Eigen::Vector3f::Constant(NAN);
  const std::optional<PinholeIntrinsics> k = IntrinsicsOfOrganisedCloud(points, 640, 480);
  ASSERT_TRUE(k.has_value());
  EXPECT_NEAR(k->fx, 525, 0.05);
  EXPECT_NEAR(k->fy, 525, 0.05);
  EXPECT_NEAR(k->cx, 319.5, 0.05);
  EXPECT_NEAR(k->cy, 239.5, 0.05);
  // Not a pinhole image (rows swapped around), the wrong size, or no points.
  std::vector<Eigen::Vector3f> scrambled = points;
  std::reverse(scrambled.begin(), scrambled.begin() + 640 * 240);
  EXPECT_FALSE(IntrinsicsOfOrganisedCloud(scrambled, 640, 480).has_value());
  EXPECT_FALSE(IntrinsicsOfOrganisedCloud(points, 320, 480).has_value());
  EXPECT_FALSE(
      IntrinsicsOfOrganisedCloud(
          std::vector<Eigen::Vector3f>(640 * 480, Eigen::Vector3f::Constant(NAN)), 640, 480)
          .has_value());
}

TEST(RenderCompare, AScanSaysWhatItSawAboutAPoint) {
  const PinholeIntrinsics k{525, 525, 319.5, 239.5};
  std::vector<Eigen::Vector3f> points = Wall(3.0f, k);
  // A hole in the wall: the pixel of (0, 0, z) has no return.
  points[239 * 640 + 319] = Eigen::Vector3f::Constant(NAN);
  auto at = [&](double x, double y, double z) {
    return VisibilityInScan(points, 640, 480, k, Eigen::Vector3d(x, y, z));
  };
  EXPECT_EQ(at(0.3, 0.2, 2.0), Visibility::kFree);             // the ray went on to the wall
  EXPECT_EQ(at(0.3, 0.2, 3.02), Visibility::kOccupied);        // the wall itself
  EXPECT_EQ(at(0.3, 0.2, 3.5), Visibility::kHidden);           // behind the wall
  EXPECT_EQ(at(-0.0005, -0.0005, 2.0), Visibility::kUnknown);  // no return there
  EXPECT_EQ(at(5.0, 0.0, 2.0), Visibility::kUnknown);          // out of view
  EXPECT_EQ(at(0.0, 0.0, -1.0), Visibility::kUnknown);         // behind the camera
  EXPECT_EQ(VisibilityInScan(points, 320, 480, k, Eigen::Vector3d(0.3, 0.2, 2.0)),
            Visibility::kUnknown);  // not the cloud's size
}

TEST(RenderCompare, SeenThroughSupportedOccludedAndUnknownPixels) {
  const PinholeIntrinsics k{525, 525, 319.5, 239.5};
  // The model: a 40 cm square panel facing the camera at 2 m, sampled every 2 cm.
  std::vector<Eigen::Vector3f> panel;
  for (int i = 0; i <= 20; ++i) {
    for (int j = 0; j <= 20; ++j) panel.emplace_back(-0.2f + 0.02f * i, -0.2f + 0.02f * j, 2.0f);
  }
  auto depth_of = [&](float z) {
    std::vector<float> depth;
    for (const Eigen::Vector3f& p : Wall(z, k)) depth.push_back(p.z());
    return depth;
  };
  const RenderComparison agree = CompareRendered(panel, depth_of(2.01f), 640, 480, k, 0.02f);
  // About the panel's 105 x 105 pixels, each drawn once.
  EXPECT_GT(agree.drawn, 100 * 100);
  EXPECT_LT(agree.drawn, 115 * 115);
  EXPECT_EQ(agree.support, agree.drawn);
  EXPECT_DOUBLE_EQ(agree.ViolationShare(), 0);
  EXPECT_DOUBLE_EQ(agree.SupportShare(), 1);
  // The sensor saw a wall 1 m behind the panel: seen through everywhere.
  const RenderComparison through = CompareRendered(panel, depth_of(3.0f), 640, 480, k, 0.02f);
  EXPECT_EQ(through.violation, through.drawn);
  EXPECT_DOUBLE_EQ(through.ViolationShare(), 1);
  // Something 1 m before it: occluded, which neither helps nor hurts.
  const RenderComparison occluded = CompareRendered(panel, depth_of(1.0f), 640, 480, k, 0.02f);
  EXPECT_EQ(occluded.occluded, occluded.drawn);
  EXPECT_DOUBLE_EQ(occluded.ViolationShare(), 0);
  // No return at all: unknown.
  const RenderComparison none =
      CompareRendered(panel, std::vector<float>(640 * 480, 0.0f), 640, 480, k, 0.02f);
  EXPECT_EQ(none.unknown, none.drawn);
  // Behind the camera or outside the image: nothing drawn.
  std::vector<Eigen::Vector3f> behind = panel;
  for (Eigen::Vector3f& p : behind) p.z() = -2;
  EXPECT_EQ(CompareRendered(behind, depth_of(2.0f), 640, 480, k, 0.02f).drawn, 0);
  std::vector<Eigen::Vector3f> aside = panel;
  for (Eigen::Vector3f& p : aside) p.x() += 5;
  EXPECT_EQ(CompareRendered(aside, depth_of(2.0f), 640, 480, k, 0.02f).drawn, 0);
}

TEST(RenderCompare, EmbreeCastsThePosedMeshAgainstTheDepth) {
  const PinholeIntrinsics k{525, 525, 319.5, 239.5};
  // A 40 cm cube standing on the floor (model frame: z up), and a camera 2 m
  // in front of it looking along the model's +y, 0.2 m above the floor.
  const std::vector<TriangleMesh> meshes{MakeBox({-0.2f, -0.2f, 0.f}, {0.2f, 0.2f, 0.4f})};
  ModelMeshCaster caster(&meshes);
  Eigen::Isometry3f camera_from_model = Eigen::Isometry3f::Identity();
  // Camera axes in model coordinates: x right = +x, y down = -z, z forward = +y.
  camera_from_model.linear() << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  camera_from_model.translation() = -(camera_from_model.linear() * Eigen::Vector3f(0, -2.2f, 0.2f));
  auto depth_of = [&](float z) {
    std::vector<float> depth;
    for (const Eigen::Vector3f& p : Wall(z, k)) depth.push_back(p.z());
    return depth;
  };
  // The front face is 2 m away: about 105 x 105 pixels, at most ~4096 rays.
  const RenderComparison agree = caster.Compare(0, camera_from_model, depth_of(2.0f), 640, 480, k);
  EXPECT_GT(agree.drawn, 500);
  EXPECT_LE(agree.drawn, 4096 * 1.2);
  EXPECT_EQ(agree.support, agree.drawn);
  const RenderComparison all =
      caster.Compare(0, camera_from_model, depth_of(2.0f), 640, 480, k, 0.f, 1 << 20);
  EXPECT_GT(all.drawn, 100 * 100);
  EXPECT_LT(all.drawn, 112 * 112);
  const RenderComparison through = caster.Compare(0, camera_from_model, depth_of(3.f), 640, 480, k);
  EXPECT_EQ(through.violation, through.drawn);
  const RenderComparison occluded =
      caster.Compare(0, camera_from_model, depth_of(1.f), 640, 480, k);
  EXPECT_EQ(occluded.occluded, occluded.drawn);
  // Above the floor band only: a band of 0.3 m hides the lower three quarters.
  const RenderComparison band =
      caster.Compare(0, camera_from_model, depth_of(2.0f), 640, 480, k, 0.3f, 1 << 20);
  EXPECT_NEAR(band.drawn, all.drawn / 4.0, all.drawn * 0.05);
  // Turned away behind the camera: nothing.
  Eigen::Isometry3f behind = camera_from_model;
  behind.translation().z() -= 5;
  EXPECT_EQ(caster.Compare(0, behind, depth_of(2.0f), 640, 480, k).drawn, 0);
  EXPECT_THROW(caster.Compare(1, camera_from_model, depth_of(2.f), 640, 480, k), InputError);
}

}  // namespace
}  // namespace furn
