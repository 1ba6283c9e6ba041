// The pieces of detection on analytic data: the 3-DOF transform, the pose
// fit over the whole circle of yaws, the occupancy grid and its visibility
// score, the floor finder, the neighbour grid, and structure (walls).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/detector.h"
#include "core/error.h"
#include "core/floor.h"
#include "core/neighbour_grid.h"
#include "core/occupancy.h"
#include "core/pose_fit.h"
#include "core/random.h"
#include "core/render_compare.h"
#include "tests/test_util.h"

namespace furn {
namespace {

double AngleError(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 2 * M_PI);
  return std::min(d, 2 * M_PI - d);
}

TEST(PoseFromPair, MapsTheModelPointOntoTheScenePointForEveryYaw) {
  const Eigen::Vector3f model(0.3f, -0.2f, 0.45f);
  for (int k = 0; k < 36; ++k) {
    const double yaw = 2 * M_PI * k / 36 + 0.01;
    const PlanarPose truth{1.5, -0.7, yaw};
    const Eigen::Vector3f scene = truth.Apply(model);
    const PlanarPose pose = PoseFromPair(scene, model, yaw);
    EXPECT_NEAR(pose.x, 1.5, 1e-5) << "yaw " << yaw;  // t = s - R m, not s - m
    EXPECT_NEAR(pose.y, -0.7, 1e-5);
    EXPECT_NEAR(AngleError(pose.yaw, yaw), 0, 1e-9);
    EXPECT_TRUE(pose.Apply(model).isApprox(scene, 1e-5f));
    EXPECT_TRUE(pose.Inverse(scene).isApprox(model, 1e-5f));
  }
  EXPECT_NEAR(WrapAngle(-M_PI / 2), 1.5 * M_PI, 1e-12);
  EXPECT_NEAR(WrapAngle(5 * M_PI), M_PI, 1e-12);
}

// An L-shaped "piece": two walls of different length with normals, 1 cm apart.
ModelShape LShape() {
  ModelShape shape;
  for (float z = 0.02f; z < 0.6f; z += 0.02f) {
    for (float x = -0.4f; x <= 0.4f; x += 0.01f) {
      shape.points.emplace_back(x, -0.25f, z);
      shape.normals.emplace_back(0, -1, 0);
    }
    for (float y = -0.25f; y <= 0.25f; y += 0.01f) {
      shape.points.emplace_back(-0.4f, y, z);
      shape.normals.emplace_back(-1, 0, 0);
    }
  }
  shape.low = shape.high = shape.points[0];
  for (const Eigen::Vector3f& p : shape.points) {
    shape.low = shape.low.cwiseMin(p);
    shape.high = shape.high.cwiseMax(p);
  }
  return shape;
}

TEST(ModelFitter, RecoversPosesOverTheWholeCircle) {
  const ModelShape shape = LShape();
  const ModelFitter fitter(shape, FitOptions{});
  Rng noise(3);
  for (double yaw_deg : {10.0, 100.0, 190.0, 250.0, 345.0}) {
    const PlanarPose truth{0.8, 1.9, yaw_deg * M_PI / 180};
    std::vector<Eigen::Vector3f> points, normals;
    for (size_t i = 0; i < shape.points.size(); i += 2) {
      Eigen::Vector3f p = truth.Apply(shape.points[i]);
      p.x() += static_cast<float>(noise.Uniform(-0.003, 0.003));
      points.push_back(p);
      normals.push_back(PlanarPose{0, 0, truth.yaw}.Apply(shape.normals[i]));
    }
    const PoseFit fit = fitter.Fit(points, normals, Eigen::Vector2f(0.95f, 1.8f), 11);
    ASSERT_TRUE(fit.found);
    EXPECT_NEAR(fit.pose.x, truth.x, 0.01) << "yaw " << yaw_deg;
    EXPECT_NEAR(fit.pose.y, truth.y, 0.01) << "yaw " << yaw_deg;
    EXPECT_LT(AngleError(fit.pose.yaw, truth.yaw) * 180 / M_PI, 1.0) << "yaw " << yaw_deg;
    EXPECT_GT(fit.Explained(), 0.95);
  }
  EXPECT_NE(testing::ErrorOf([] {
              FitOptions bad;
              bad.inlier_m = 0;
              bad.Check();
            }).find("inlier"),
            std::string::npos);
}

TEST(OccupancyGrid, FreeBeforeASurfaceOccupiedOnItUnknownBehind) {
  // A wall at x = 2 m seen from the origin.
  std::vector<Eigen::Vector3f> wall;
  for (float y = -0.5f; y <= 0.5f; y += 0.02f) {
    for (float z = -0.5f; z <= 0.5f; z += 0.02f) wall.emplace_back(2.0f, y, z);
  }
  const OccupancyGrid grid(wall, Eigen::Vector3f::Zero(), 0.05);
  EXPECT_EQ(grid.At(Eigen::Vector3f(1.0f, 0, 0)), Occupancy::kFree);
  EXPECT_EQ(grid.At(Eigen::Vector3f(2.0f, 0.1f, 0.1f)), Occupancy::kOccupied);
  EXPECT_EQ(grid.At(Eigen::Vector3f(2.3f, 0, 0)), Occupancy::kUnknown);
  EXPECT_EQ(grid.At(Eigen::Vector3f(50, 0, 0)), Occupancy::kUnknown);  // outside the grid
  // Model points in front of the wall are in free space: a low score; on it
  // and behind it: a high one (vs = (5 occ + occl) / (5 occ + occl + free)).
  std::vector<Eigen::Vector3f> floating, on_wall;
  for (float y = -0.2f; y <= 0.2f; y += 0.05f) {
    floating.emplace_back(1.0f, y, 0);
    on_wall.emplace_back(2.0f, y, 0);
    on_wall.emplace_back(2.3f, y, 0);
  }
  const VisibilityCounts in_front = CountVisibility(grid, floating, -10);
  EXPECT_EQ(in_front.free, static_cast<int>(floating.size()));
  EXPECT_DOUBLE_EQ(in_front.Score(5), 0.0);
  const VisibilityCounts behind = CountVisibility(grid, on_wall, -10);
  EXPECT_EQ(behind.free, 0);
  EXPECT_EQ(behind.occupied, behind.occluded);
  EXPECT_DOUBLE_EQ(behind.Score(5), 1.0);
  EXPECT_DOUBLE_EQ(behind.SeenOccupied(), 1.0);
}

// Camera-frame points of a floor 1.3 m below a camera pitched down 25
// degrees, plus a box standing on it.
std::vector<Eigen::Vector3f> FloorScan(bool with_floor) {
  const double pitch = 25 * M_PI / 180;
  // World: z up, camera at (0, 0, 1.3) looking along +y, pitched down.
  const Eigen::Vector3d forward(0, std::cos(pitch), -std::sin(pitch));
  const Eigen::Vector3d right(1, 0, 0);
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d camera_from_world;
  camera_from_world.row(0) = right.transpose();
  camera_from_world.row(1) = down.transpose();
  camera_from_world.row(2) = forward.transpose();
  const Eigen::Vector3d eye(0, 0, 1.3);
  std::vector<Eigen::Vector3f> points;
  for (double x = -1.5; x <= 1.5; x += 0.03) {
    for (double y = 1.0; y <= 4.0; y += 0.03) {
      if (with_floor)
        points.push_back((camera_from_world * (Eigen::Vector3d(x, y, 0) - eye)).cast<float>());
    }
    for (double z = 0.0; z <= 2.4; z += 0.03)  // the far wall
      points.push_back((camera_from_world * (Eigen::Vector3d(x, 4.0, z) - eye)).cast<float>());
  }
  for (double x = -0.2; x <= 0.2; x += 0.02) {  // a box's top at 0.5 m
    for (double y = 2.0; y <= 2.4; y += 0.02)
      points.push_back((camera_from_world * (Eigen::Vector3d(x, y, 0.5) - eye)).cast<float>());
  }
  return points;
}

TEST(FindFloor, FindsTheFloorAndTheCameraHeight) {
  const Eigen::Isometry3d world_from_camera = FindFloor(FloorScan(true), FloorOptions{});
  EXPECT_NEAR(world_from_camera.translation().z(), 1.3, 0.01);
  // The camera's optical axis points 25 degrees below the horizon.
  const Eigen::Vector3d axis = world_from_camera.linear() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(std::asin(-axis.z()) * 180 / M_PI, 25, 0.5);
  // A floor point lands on z = 0.
  const Eigen::Vector3f any_floor_point = FloorScan(true)[0];
  EXPECT_NEAR((world_from_camera * any_floor_point.cast<double>()).z(), 0, 0.01);
}

TEST(FindFloor, NoFloorAndTooFewPointsAreErrors) {
  EXPECT_NE(
      testing::ErrorOf([] { FindFloor(FloorScan(false), FloorOptions{}); }).find("no floor found"),
      std::string::npos);
  EXPECT_NE(testing::ErrorOf([] {
              FindFloor(std::vector<Eigen::Vector3f>(10, Eigen::Vector3f(0, 1, 2)), FloorOptions{});
            }).find("at least 100"),
            std::string::npos);
}

TEST(NeighbourGrid, MatchesBruteForce) {
  Rng rng(5);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 2000; ++i) {
    points.emplace_back(rng.Uniform(-0.5, 0.5), rng.Uniform(-0.5, 0.5), rng.Uniform(-0.1, 0.1));
  }
  const NeighbourGrid grid(points, 0.05f);
  for (int i = 0; i < 2000; i += 97) {
    std::vector<int> fast, slow;
    grid.ForEachNeighbourOf(i, 0.05f, [&](int j, float) { fast.push_back(j); });
    std::vector<int> by_point;
    grid.ForEachWithin(points[i], 0.05f, [&](int j, float) { by_point.push_back(j); });
    for (int j = 0; j < 2000; ++j) {
      if ((points[j] - points[i]).norm() <= 0.05f) slow.push_back(j);
    }
    std::sort(fast.begin(), fast.end());
    std::sort(by_point.begin(), by_point.end());
    EXPECT_EQ(fast, slow);
    EXPECT_EQ(by_point, slow);
  }
}

// A wall 2 m wide at y = 2 (noisy, split into one large segment and many
// small ones, as Kinect noise splits a wall seen head-on), a box's front
// 60 cm before it, and a small piece of another wall beyond its span.
ViewSegments WallScene(float wall_top) {
  ViewSegments view;
  Rng rng(5);
  auto add = [&](const Eigen::Vector3f& p, std::vector<int>* segment) {
    segment->push_back(static_cast<int>(view.cloud.points.size()));
    view.cloud.points.push_back(p);
    view.cloud.normals.emplace_back(0, -1, 0);
    view.cloud.curvature.push_back(0);
  };
  std::vector<int> wall;
  std::vector<std::vector<int>> fragments(8);
  for (float x = -1; x <= 1; x += 0.04f) {
    for (float z = 0.1f; z <= wall_top; z += 0.04f) {
      const Eigen::Vector3f p(x, 2 + static_cast<float>(rng.Uniform(-0.01, 0.01)), z);
      const int cell = static_cast<int>(std::lround(x / 0.04f + z / 0.04f));
      if (z < 1.0f && cell % 3 == 0) {  // below 1 m every third point is in a fragment
        add(p, &fragments[static_cast<int>((x + 1) / 0.25f) % 8]);
      } else {
        add(p, &wall);
      }
    }
  }
  std::vector<int> box, far_piece;
  for (float x = -0.5f; x <= 0.5f; x += 0.04f) {
    for (float z = 0; z <= 0.8f; z += 0.04f) add(Eigen::Vector3f(x, 1.4f, z), &box);
  }
  for (float x = 2.5f; x <= 2.8f; x += 0.04f) {
    for (float z = 0.2f; z <= 0.6f; z += 0.04f) add(Eigen::Vector3f(x, 2, z), &far_piece);
  }
  view.segments = {wall, box, far_piece};
  for (const auto& fragment : fragments) view.segments.push_back(fragment);
  return view;
}

TEST(FindStructure, WallsAndTheirFragmentsButNotFurnitureBeforeThem) {
  const ViewSegments view = WallScene(2.2f);
  std::vector<char> segment_flags;
  const std::vector<char> structure = FindStructure(view, 2.5, 1.4f, &segment_flags);
  ASSERT_EQ(structure.size(), view.cloud.size());
  ASSERT_EQ(segment_flags.size(), view.segments.size());
  EXPECT_TRUE(segment_flags[0]);   // the wall: 2.1 m across, but reaching 2.2 m
  EXPECT_FALSE(segment_flags[1]);  // the box
  EXPECT_FALSE(segment_flags[2]);  // on the wall's plane but beyond its span
  for (size_t s = 3; s < view.segments.size(); ++s) EXPECT_TRUE(segment_flags[s]) << s;
  for (int i : view.segments[1]) ASSERT_FALSE(structure[i]);
  for (int i : view.segments[2]) ASSERT_FALSE(structure[i]);
  for (size_t s = 3; s < view.segments.size(); ++s) {
    for (int i : view.segments[s]) ASSERT_TRUE(structure[i]);
  }
}

TEST(FindStructure, ALowNarrowSegmentIsNotStructure) {
  const ViewSegments view = WallScene(1.2f);  // a 2 m x 1.1 m board, lower than 1.4 m
  std::vector<char> segment_flags;
  const std::vector<char> structure = FindStructure(view, 2.5, 1.4f, &segment_flags);
  for (char flag : structure) ASSERT_FALSE(flag);
  // Wider than max_extent makes it structure whatever its height.
  FindStructure(view, 1.5, 1.4f, &segment_flags);
  EXPECT_TRUE(segment_flags[0]);
  EXPECT_TRUE(segment_flags[3]);
  EXPECT_FALSE(segment_flags[1]);
}

}  // namespace
}  // namespace furn

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
