// Preprocessing, region growing and the 24 SGFs against analytic point sets
// and a ray-cast scan of a procedural chair.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/codebook/preprocess.h"
#include "core/codebook/region_growing.h"
#include "core/codebook/sgf.h"
#include "core/geometry/scene.h"
#include "core/util/error.h"
#include "renderers/embree_caster.h"
#include "scenes/procedural_catalog.h"

namespace furn {
namespace {

// Points of a grid with the given normal, curvature 0.
PointCloud Grid(int nx, int ny, double step, const Eigen::Vector3f& normal) {
  PointCloud cloud;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) {
      cloud.points.emplace_back(step * (i + 0.5), step * (j + 0.5), 0.0f);
      cloud.normals.push_back(normal);
      cloud.curvature.push_back(0);
    }
  }
  return cloud;
}

std::vector<int> All(const PointCloud& cloud) {
  std::vector<int> indices(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) indices[i] = static_cast<int>(i);
  return indices;
}

TEST(Sgf, PlanePatchMatchesHandComputedValues) {
  // 80 x 40 points, 5 mm apart: a 0.4 x 0.2 m patch in the plane z = 0.
  const PointCloud plane = Grid(80, 40, 0.005, Eigen::Vector3f::UnitZ());
  const SgfVector f = ComputeSgf(plane, All(plane), SgfOptions{});
  // Variance of N evenly spaced points: (N^2 - 1) h^2 / 12.
  const double v1 = (80.0 * 80 - 1) * 0.005 * 0.005 / 12, v2 = (40.0 * 40 - 1) * 0.005 * 0.005 / 12;
  EXPECT_NEAR(f[9], v1, 1e-9);
  EXPECT_NEAR(f[10], v2, 1e-9);
  EXPECT_NEAR(f[11], 0, 1e-12);
  EXPECT_NEAR(f[3], v2 / v1, 1e-6);  // e2 / e1 (points are floats)
  EXPECT_NEAR(f[4], 0, 1e-9);        // e3 / e2: flat
  EXPECT_NEAR(f[6], v1 / (v1 + v2), 1e-6);
  EXPECT_NEAR(f[12], 1, 1e-9);      // smallest axis is z
  EXPECT_NEAR(f[13], 0.395, 1e-6);  // extents: (N - 1) h
  EXPECT_NEAR(f[14], 0.195, 1e-6);
  EXPECT_NEAR(f[15], 0, 1e-6);
  EXPECT_NEAR(f[16], 1, 1e-6);  // symmetric about the centroid
  EXPECT_NEAR(f[19], 0.395 / 0.195, 1e-6);
  EXPECT_NEAR(f[20], v1 / 0.395, 1e-9);
  EXPECT_NEAR(f[2], 800 * 1e-6, 1e-12);  // 40 x 20 occupied 1 cm voxels
  EXPECT_NEAR(f[23], 800e-6 / (0.395 * 0.195 * 0.01), 1e-6);
  // Boundary points: at least the outer ring, well under half.
  EXPECT_GE(f[0], (2 * (80 + 40) - 4) / 3200.0);
  EXPECT_LT(f[0], 0.3);
}

TEST(Sgf, SolidCubeIsIsotropic) {
  PointCloud cube;
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 20; ++j) {
      for (int k = 0; k < 20; ++k) {
        // Voxel centres, so each point falls clearly inside its 1 cm voxel.
        cube.points.emplace_back(0.005f + 0.01f * i, 0.005f + 0.01f * j, 0.005f + 0.01f * k);
        cube.normals.emplace_back(0, 0, 1);
        cube.curvature.push_back(0.1f);
      }
    }
  }
  const SgfVector f = ComputeSgf(cube, All(cube), SgfOptions{});
  EXPECT_NEAR(f[3], 1, 1e-6);
  EXPECT_NEAR(f[4], 1, 1e-6);
  EXPECT_NEAR(f[7], 1.0 / 3, 1e-6);
  EXPECT_NEAR(f[1], 0.1, 1e-6);  // mean curvature
  // Equal eigenvalues: the axes are arbitrary, so only the variances are fixed.
  const double v = (20.0 * 20 - 1) * 0.01 * 0.01 / 12;
  for (int k = 9; k < 12; ++k) EXPECT_NEAR(f[k], v, 1e-6);
  EXPECT_NEAR(f[2], 8000e-6, 1e-9);  // every 1 cm voxel occupied
}

TEST(Sgf, VerticalCylinderHasItsAxisUpright) {
  PointCloud cylinder;
  const double r = 0.1, h = 0.6;
  for (int i = 0; i < 120; ++i) {
    for (int j = 0; j < 121; ++j) {
      const double a = 2 * M_PI * i / 120;
      cylinder.points.emplace_back(r * std::cos(a), r * std::sin(a), h * j / 120);
      cylinder.normals.emplace_back(std::cos(a), std::sin(a), 0);
      cylinder.curvature.push_back(0.05f);
    }
  }
  const SgfVector f = ComputeSgf(cylinder, All(cylinder), SgfOptions{});
  // Along the axis: variance h^2 (N + 1) / (12 (N - 1)); across: r^2 / 2 each.
  EXPECT_NEAR(f[9], h * h * 122.0 / (12 * 120), 1e-6);
  EXPECT_NEAR(f[10], r * r / 2, 1e-6);
  EXPECT_NEAR(f[4], 1, 1e-6);   // e3 / e2: round
  EXPECT_NEAR(f[12], 0, 1e-6);  // the smallest axis is horizontal
  EXPECT_NEAR(f[13], h, 1e-6);
  EXPECT_NEAR(f[14], 2 * r, 1e-3);
}

TEST(Sgf, InvariantToRotationAboutZAndEigenvectorSigns) {
  PointCloud patch = Grid(30, 12, 0.01, Eigen::Vector3f::UnitZ());
  for (size_t i = 0; i < patch.size(); ++i)
    patch.points[i].z() = 0.02f * std::sin(patch.points[i].x() * 9);
  PointCloud turned = patch;
  const Eigen::Matrix3f half_turn =
      Eigen::AngleAxisf(static_cast<float>(M_PI), Eigen::Vector3f::UnitZ()).matrix();
  for (Eigen::Vector3f& p : turned.points) p = half_turn * p + Eigen::Vector3f(3, 2, 0);
  const SgfOptions options;
  const SgfVector a = ComputeSgf(patch, All(patch), options),
                  b = ComputeSgf(turned, All(turned), options);
  for (int k = 0; k < kSgfCount; ++k) {
    if (k == 2 || k == 23) continue;  // voxel counts depend on the grid's alignment
    EXPECT_NEAR(a[k], b[k], 1e-5 * std::max(1.0, std::abs(a[k]))) << "feature " << k;
  }
}

TEST(Sgf, TooSmallSegmentIsRejected) {
  const PointCloud plane = Grid(2, 1, 0.01, Eigen::Vector3f::UnitZ());
  EXPECT_THROW(ComputeSgf(plane, All(plane), SgfOptions{}), InputError);
}

TEST(RegionGrowing, APlaneStaysOneSegment) {
  const PointCloud plane = Grid(60, 60, 0.01, Eigen::Vector3f::UnitZ());
  const auto segments = GrowRegions(plane, RegionGrowingOptions{});
  ASSERT_EQ(segments.size(), 1u);
  EXPECT_EQ(segments[0].size(), plane.size());
}

TEST(RegionGrowing, TwoPlanesAtRightAnglesSplit) {
  PointCloud corner = Grid(40, 40, 0.01, Eigen::Vector3f::UnitZ());
  const PointCloud wall = Grid(40, 40, 0.01, Eigen::Vector3f::UnitX());
  for (size_t i = 0; i < wall.size(); ++i) {
    corner.points.emplace_back(0, wall.points[i].y(), wall.points[i].x());
    corner.normals.push_back(Eigen::Vector3f::UnitX());
    corner.curvature.push_back(0);
  }
  const auto segments = GrowRegions(corner, RegionGrowingOptions{});
  ASSERT_EQ(segments.size(), 2u);
  EXPECT_EQ(segments[0].size(), 1600u);
  EXPECT_EQ(segments[1].size(), 1600u);
}

TEST(RegionGrowing, BadOptionsAreRejected) {
  RegionGrowingOptions options;
  options.alpha_deg = 0;
  EXPECT_THROW(GrowRegions(PointCloud{}, options), InputError);
  PreprocessOptions preprocess;
  preprocess.normal_radius_m = 5;
  EXPECT_THROW(Preprocess({}, Eigen::Vector3f::Zero(), preprocess), InputError);
}

// A ray-cast scan of a procedural chair from the front left, above.
TEST(RegionGrowing, SplitsAScannedChairIntoSeatBackAndLegs) {
  const ProceduralModel chair = MakeProceduralModel(FurnitureClass::kChair, 3);
  const Box3 box = BoundingBox(chair.model.mesh);
  Scene scene;
  scene.objects.push_back(
      {std::make_shared<TriangleMesh>(chair.model.mesh), Eigen::Isometry3d::Identity(), 10});
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const Eigen::Vector3d eye(-0.5, -1.3, 1.1);
  const Eigen::Isometry3d world_from_camera = LookAlong(eye, Eigen::Vector3d(0, 0, 0.35) - eye);
  EmbreeCaster caster;
  const DepthFrame frame = caster.Render(scene, camera, world_from_camera);
  std::vector<Eigen::Vector3f> points;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const float z = frame.DepthAt(u, v);
      if (z > 0)
        points.push_back(
            (world_from_camera * (z * camera.RayThroughPixel(u, v)).cast<double>()).cast<float>());
    }
  }
  const PointCloud cloud = Preprocess(points, eye.cast<float>(), PreprocessOptions{});
  ASSERT_GT(cloud.size(), 1000u);
  RegionGrowingOptions options;
  options.min_segment_size = 10;
  const auto segments = GrowRegions(cloud, options);

  // The seat: the highest horizontal surface below the back. Find the seat top
  // as the segment whose normal is up and whose points lie around mid-height.
  int seat_segments = 0, back_segments = 0, leg_segments = 0;
  for (const std::vector<int>& segment : segments) {
    Eigen::Vector3f mean_normal = Eigen::Vector3f::Zero();
    float z_min = 1e9f, z_max = -1e9f;
    for (int i : segment) {
      mean_normal += cloud.normals[i];
      z_min = std::min(z_min, cloud.points[i].z());
      z_max = std::max(z_max, cloud.points[i].z());
    }
    mean_normal.normalize();
    if (mean_normal.z() > 0.9f && z_min > 0.3f && z_max < 0.55f) ++seat_segments;
    if (z_min > 0.45f && z_max > box.max.z() - 0.05f && std::abs(mean_normal.z()) < 0.4f)
      ++back_segments;
    if (z_max < 0.45f && segment.size() >= 10 && std::abs(mean_normal.z()) < 0.4f) ++leg_segments;
    // The front of the back and the front of the legs are split by the seat.
    // (The chair's side may stay one segment: back board, seat edge and rear
    // leg are coplanar there, closer than delta, as the algorithm intends.)
    if (mean_normal.y() < -0.9f) {
      EXPECT_FALSE(z_min < 0.1f && z_max > box.max.z() - 0.1f)
          << "a front segment mixes legs and back";
    }
  }
  EXPECT_EQ(seat_segments, 1);
  EXPECT_GE(back_segments, 1);
  EXPECT_GE(leg_segments, 2);
}

}  // namespace
}  // namespace furn

#include "core/codebook/part_subsets.h"

namespace furn {
namespace {

// Three touching strips side by side: segments 0-1 and 1-2 are adjacent.
ViewSegments ThreeStrips() {
  ViewSegments view;
  for (int strip = 0; strip < 3; ++strip) {
    std::vector<int> segment;
    for (int i = 0; i < 10; ++i) {
      for (int j = 0; j < 10; ++j) {
        segment.push_back(static_cast<int>(view.cloud.points.size()));
        view.cloud.points.emplace_back(0.1f * strip + 0.01f * i, 0.01f * j, 0.0f);
        view.cloud.normals.push_back(Eigen::Vector3f::UnitZ());
        view.cloud.curvature.push_back(0);
      }
    }
    view.segments.push_back(segment);
  }
  return view;
}

TEST(PartSubsets, SingletonsAdjacentPairsAndConnectedTriples) {
  const ViewSegments view = ThreeStrips();
  const auto subsets = PartSubsets(view, PartSubsetOptions{});
  const std::vector<std::vector<int>> expected = {{0}, {1}, {2}, {0, 1}, {1, 2}, {0, 1, 2}};
  EXPECT_EQ(subsets, expected);  // 0 and 2 do not touch: no pair {0, 2}
  PartSubsetOptions options;
  options.min_subset_size = 2;
  EXPECT_EQ(PartSubsets(view, options), (std::vector<std::vector<int>>{{0, 1}, {1, 2}, {0, 1, 2}}));
  options.min_subset_size = 4;
  EXPECT_THROW(PartSubsets(view, options), InputError);
  // VFH of a subset: 308 bins that are not all zero.
  const VfhDescriptor vfh = ComputeVfh(view.cloud, view.segments[0], Eigen::Vector3f(0, 0, 2));
  float total = 0;
  for (float bin : vfh) total += bin;
  EXPECT_GT(total, 0);
}

// The paper's VFH leaves its shape-distribution bins (135..179) empty. With
// the size component they hold the points' distances from the centroid in
// centimetres: the same part twice as large fills bins twice as far.
TEST(PartSubsets, VfhSizeComponentTellsTheSameShapeAtTwoSizesApart) {
  // A cap of a 20 cm sphere (normals outwards), and the same twice as large.
  PointCloud small, large;
  for (int i = 1; i <= 15; ++i) {
    for (int j = 0; j < 20; ++j) {
      const float theta = 0.07f * i, phi = 0.314159f * j;
      const Eigen::Vector3f normal(
          std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      small.points.push_back(0.2f * normal);
      small.normals.push_back(normal);
      small.curvature.push_back(0);
      large.points.push_back(0.4f * normal);
      large.normals.push_back(normal);
      large.curvature.push_back(0);
    }
  }
  std::vector<int> all(small.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const Eigen::Vector3f viewpoint(0.1f, 0.3f, 1.0f);
  // The shape-distribution part of the VFH: bins 135..179.
  auto size_distance = [](const VfhDescriptor& a, const VfhDescriptor& b) {
    float sum = 0;
    for (int i = 135; i < 180; ++i) sum += (a[i] - b[i]) * (a[i] - b[i]);
    return std::sqrt(sum);
  };
  const VfhDescriptor plain_small = ComputeVfh(small, all, viewpoint);
  const VfhDescriptor plain_large = ComputeVfh(large, all, 2 * viewpoint);
  const VfhDescriptor empty{};
  EXPECT_EQ(size_distance(plain_small, empty), 0);  // the paper's VFH leaves them empty
  EXPECT_EQ(size_distance(plain_large, empty), 0);
  const VfhDescriptor sized_small = ComputeVfh(small, all, viewpoint, true);
  const VfhDescriptor sized_large = ComputeVfh(large, all, 2 * viewpoint, true);
  EXPECT_GT(size_distance(sized_small, sized_large), 20.0f);
  for (int i = 0; i < 308; ++i) {  // the rest as without it
    if (i < 135 || i >= 180) {
      EXPECT_EQ(sized_small[i], plain_small[i]) << "bin " << i;
    }
  }
  // Centimetre bins: the farthest point from the centroid lands twice as far.
  auto last_filled = [](const VfhDescriptor& d) {
    int last = -1;
    for (int i = 135; i < 180; ++i)
      if (d[i] > 0) last = i - 135;
    return last;
  };
  EXPECT_GT(last_filled(sized_small), 5);
  EXPECT_NEAR(last_filled(sized_large), 2 * last_filled(sized_small), 2);
}

// The index searches exactly in its principal components: against brute
// force in double over the same projected rows, many queries at once give
// what each gives alone, over more rows than one block (8192).
TEST(PartSubsets, IndexFindsTheExactNearestInItsComponents) {
  std::mt19937_64 random(5);
  std::normal_distribution<float> gaussian(0, 1);
  std::vector<VfhDescriptor> library(20000);
  for (VfhDescriptor& d : library) {
    for (float& bin : d) bin = gaussian(random);
  }
  const PartSubsetIndex index(library, 16);
  ASSERT_EQ(index.size(), library.size());
  const Eigen::MatrixXf& projected = index.state().projected;
  std::vector<VfhDescriptor> queries = {library[17], library[19999], library[8192]};
  for (int i = 0; i < 4; ++i) {
    VfhDescriptor d;
    for (float& bin : d) bin = gaussian(random);
    queries.push_back(d);
  }
  const int k = 7;
  const std::vector<std::vector<int>> many = index.NearestMany(queries, k);
  ASSERT_EQ(many.size(), queries.size());
  for (size_t j = 0; j < queries.size(); ++j) {
    EXPECT_EQ(index.Nearest(queries[j], k), many[j]) << "query " << j;
    const Eigen::RowVectorXd q =
        ((Eigen::Map<const Eigen::RowVectorXf>(queries[j].data(), 308) - index.state().mean) *
         index.state().basis)
            .cast<double>();
    std::vector<double> truth(projected.rows());
    for (Eigen::Index r = 0; r < projected.rows(); ++r)
      truth[r] = (projected.row(r).cast<double>() - q).squaredNorm();
    std::vector<double> sorted = truth;
    std::partial_sort(sorted.begin(), sorted.begin() + k, sorted.end());
    ASSERT_EQ(many[j].size(), static_cast<size_t>(k));
    for (int r = 0; r < k; ++r)  // the r-th found is as near as the true r-th (float rounding)
      EXPECT_NEAR(truth[many[j][r]], sorted[r], 1e-3 * (1 + sorted[r])) << "query " << j;
  }
  EXPECT_EQ(many[0].front(), 17);  // a library descriptor finds itself
  EXPECT_EQ(many[1].front(), 19999);
  EXPECT_EQ(many[2].front(), 8192);
  EXPECT_TRUE(index.NearestMany({}, k).empty());
  EXPECT_TRUE(index.Nearest(queries[0], 0).empty());
}

}  // namespace
}  // namespace furn
