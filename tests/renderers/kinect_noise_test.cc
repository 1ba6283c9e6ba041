// The Kinect v1 model against its formulas: axial noise, quantisation steps,
// projector shadow width and side, determinism, option checks.
#include "renderers/kinect_noise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <set>

#include "core/util/error.h"
#include "renderers/depth_renderer.h"
#include "renderers/kinect_simulator.h"
#include "tests/renderers/render_fixtures.h"

namespace furn {
namespace {

KinectNoiseOptions AllOff() {
  KinectNoiseOptions options;
  options.projector_shadow = false;
  options.range_limits = false;
  options.incidence_dropout = false;
  options.edge_dropout = false;
  options.lateral_noise = false;
  options.axial_noise = false;
  options.quantization = false;
  return options;
}

// The ideal frame of a fronto-parallel wall at `distance`.
DepthFrame WallFrame(double distance) {
  Scene scene;
  scene.objects.push_back(testing::WallAt(distance));
  return MakeRenderer(RendererKind::kEmbree)
      ->Render(scene, CameraIntrinsics::KinectV1(), testing::CameraAtOriginLookingAlongY());
}

double StdDev(const std::vector<float>& values) {
  double sum = 0, sum2 = 0;
  size_t n = 0;
  for (float x : values) {
    if (x <= 0) continue;
    sum += x;
    sum2 += static_cast<double>(x) * x;
    ++n;
  }
  const double mean = sum / n;
  return std::sqrt(sum2 / n - mean * mean);
}

TEST(KinectNoise, AxialNoiseMatchesNguyenAt1_2_3Metres) {
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  KinectNoiseOptions options = AllOff();
  options.axial_noise = true;
  for (double distance : {1.0, 2.0, 3.0}) {
    const DepthFrame noisy = ApplyKinectNoise(WallFrame(distance), camera, options, 7);
    // Off-axis rays meet the wall at up to ~29 degrees, below the 60-degree
    // term, so every pixel has sigma_z of the formula's first part.
    const double expected = AxialNoiseSigma(distance, 0.0);
    const double measured = StdDev(noisy.depth);
    EXPECT_NEAR(measured, expected, 0.15 * expected) << "at " << distance << " m";
  }
  EXPECT_NEAR(AxialNoiseSigma(1.0, 0.0), 0.0012 + 0.0019 * 0.36, 1e-12);  // not squared
  EXPECT_GT(AxialNoiseSigma(2.0, 70 * M_PI / 180), AxialNoiseSigma(2.0, 0.0));
  EXPECT_NEAR(LateralNoiseSigmaPx(0.0), 0.8, 1e-12);
}

TEST(KinectNoise, QuantisationStepsAreOneEighthPixelOfDisparity) {
  // A floor seen obliquely: depths sweep 1..4 m, so many disparity steps occur.
  Scene scene;
  scene.objects.push_back({std::make_shared<TriangleMesh>(MakeBox({-5, 0, -0.1f}, {5, 10, 0})),
                           Eigen::Isometry3d::Identity(),
                           kFloorId});
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const Eigen::Isometry3d world_from_camera =
      LookAlong(Eigen::Vector3d(0, -1, 1.0), Eigen::Vector3d(0, 1, -0.5));
  const DepthFrame ideal =
      MakeRenderer(RendererKind::kOsMesa)->Render(scene, camera, world_from_camera);
  KinectNoiseOptions options = AllOff();
  options.quantization = true;
  const DepthFrame noisy = ApplyKinectNoise(ideal, camera, options, 1);
  const double fb = camera.fx * options.baseline_m;
  std::set<float> levels;
  for (float z : noisy.depth) {
    if (z <= 0) continue;
    const double eighths = 8 * fb / z;
    ASSERT_NEAR(eighths, std::round(eighths), 1e-3)
        << "depth " << z << " is not on a disparity step";
    levels.insert(z);
  }
  ASSERT_GT(levels.size(), 100u);
  // Neighbouring levels differ by the predicted step dz = z^2 / (8 fx b).
  const std::vector<float> sorted(levels.begin(), levels.end());
  for (size_t i = 0; i + 1 < sorted.size(); ++i) {
    const double z = 0.5 * (sorted[i] + sorted[i + 1]);
    const double predicted = z * z / (8 * fb);
    EXPECT_NEAR(sorted[i + 1] - sorted[i], predicted, 0.02 * predicted) << "at " << z << " m";
  }
  // At 2 m that step is the ~11.5 mm banding of real Kinect clouds.
  EXPECT_NEAR(4.0 / (8 * fb), 0.0115, 0.0002);
}

TEST(KinectNoise, BoxCastsProjectorShadowToItsLeftWithPredictedWidth) {
  const double z_box = 1.5, z_wall = 2.5;
  Scene scene;
  scene.objects.push_back(testing::WallAt(z_wall));
  scene.objects.push_back(testing::BoxAt(z_box, -0.2, 0.2, -0.2, 0.2, 42));
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  KinectNoiseOptions options = AllOff();
  options.projector_shadow = true;
  const double predicted_px = camera.fx * options.baseline_m * (1 / z_box - 1 / z_wall);  // 11.6 px
  for (RendererKind kind : {RendererKind::kOsMesa, RendererKind::kEmbree}) {
    const DepthFrame ideal =
        MakeRenderer(kind)->Render(scene, camera, testing::CameraAtOriginLookingAlongY());
    const DepthFrame noisy = ApplyKinectNoise(ideal, camera, options, 1);
    for (int v : {200, 240, 280}) {
      int left_box_edge = -1, right_box_edge = -1;
      for (int u = 0; u < camera.width; ++u) {
        if (ideal.IdAt(u, v) == 42) {
          if (left_box_edge < 0) left_box_edge = u;
          right_box_edge = u;
        }
      }
      ASSERT_GT(left_box_edge, 0);
      int shadow_left = 0, shadow_right = 0;
      for (int u = 0; u < left_box_edge; ++u) shadow_left += noisy.DepthAt(u, v) == 0;
      for (int u = right_box_edge + 1; u < camera.width; ++u)
        shadow_right += noisy.DepthAt(u, v) == 0;
      EXPECT_NEAR(shadow_left, predicted_px, 1.5) << "row " << v;
      EXPECT_EQ(shadow_right, 0) << "row " << v;
      // The shadow is next to the box, not elsewhere on the row.
      EXPECT_EQ(noisy.DepthAt(left_box_edge - 1, v), 0.0f);
      EXPECT_GT(noisy.DepthAt(left_box_edge - static_cast<int>(predicted_px) - 2, v), 0.0f);
    }
  }
}

TEST(KinectNoise, RangeAndIncidenceDropout) {
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  KinectNoiseOptions options = AllOff();
  options.range_limits = true;
  EXPECT_EQ(ApplyKinectNoise(WallFrame(0.4), camera, options, 1).NumValid(), 0u);
  EXPECT_EQ(ApplyKinectNoise(WallFrame(5.0), camera, options, 1).NumValid(), 0u);
  EXPECT_EQ(ApplyKinectNoise(WallFrame(3.0), camera, options, 1).NumValid(), 307200u);
  // A floor seen from 1 m up: incidence grows towards the horizon; beyond 78
  // degrees, no return.
  Scene scene;
  scene.objects.push_back({std::make_shared<TriangleMesh>(MakeBox({-20, 0, -0.1f}, {20, 40, 0})),
                           Eigen::Isometry3d::Identity(),
                           kFloorId});
  const DepthFrame ideal =
      MakeRenderer(RendererKind::kEmbree)
          ->Render(scene, camera, LookAlong(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0, 1, -0.2)));
  options = AllOff();
  options.incidence_dropout = true;
  const DepthFrame noisy = ApplyKinectNoise(ideal, camera, options, 1);
  size_t dropped_steep = 0, kept_steep = 0, dropped_shallow = 0;
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u) {
      const size_t i = ideal.Index(u, v);
      if (ideal.depth[i] <= 0) continue;
      const double cosine =
          std::abs(ideal.normals[i].dot(camera.RayThroughPixel(u, v).normalized()));
      const double angle = std::acos(cosine) * 180 / M_PI;
      if (angle > 78.5) {
        (noisy.depth[i] == 0 ? dropped_steep : kept_steep)++;
      } else if (angle < 77.5) {
        dropped_shallow += noisy.depth[i] == 0;
      }
    }
  }
  EXPECT_GT(dropped_steep, 1000u);
  EXPECT_EQ(kept_steep, 0u);
  EXPECT_EQ(dropped_shallow, 0u);
}

TEST(KinectNoise, LateralNoiseMakesEdgesRagged) {
  Scene scene;
  scene.objects.push_back(testing::WallAt(3.0));
  scene.objects.push_back(testing::BoxAt(1.5, -0.2, 0.2, -0.2, 0.2, 42));
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const DepthFrame ideal = MakeRenderer(RendererKind::kOsMesa)
                               ->Render(scene, camera, testing::CameraAtOriginLookingAlongY());
  KinectNoiseOptions options = AllOff();
  options.lateral_noise = true;
  const DepthFrame noisy = ApplyKinectNoise(ideal, camera, options, 3);
  // The right edge column of the box differs between rows; the inside does not.
  std::set<int> edge_columns;
  for (int v = 180; v < 300; ++v) {
    int right = 0;
    for (int u = 320; u < camera.width; ++u) {
      if (noisy.IdAt(u, v) == 42) right = u;
    }
    edge_columns.insert(right);
  }
  EXPECT_GE(edge_columns.size(), 3u);
  EXPECT_EQ(noisy.IdAt(320, 240), 42);
}

TEST(KinectNoise, SameSeedSameBytesDifferentSeedDifferent) {
  const Scene scene = testing::FurnishedRoom(2);
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  auto renderer = MakeRenderer(RendererKind::kOsMesa);
  const KinectNoiseOptions options;
  const KinectCapture a =
      CaptureKinect(renderer.get(), scene, camera, testing::FurnishedRoomCamera(), options, 5);
  const KinectCapture b =
      CaptureKinect(renderer.get(), scene, camera, testing::FurnishedRoomCamera(), options, 5);
  const KinectCapture c =
      CaptureKinect(renderer.get(), scene, camera, testing::FurnishedRoomCamera(), options, 6);
  ASSERT_EQ(a.noisy.depth.size(), b.noisy.depth.size());
  EXPECT_EQ(std::memcmp(a.noisy.depth.data(), b.noisy.depth.data(), a.noisy.depth.size() * 4), 0);
  EXPECT_EQ(a.noisy.instance_ids, b.noisy.instance_ids);
  EXPECT_EQ(std::memcmp(a.ideal.depth.data(), b.ideal.depth.data(), a.ideal.depth.size() * 4), 0);
  EXPECT_NE(std::memcmp(a.noisy.depth.data(), c.noisy.depth.data(), a.noisy.depth.size() * 4), 0);
}

TEST(KinectNoise, BadOptionsAndMismatchedFramesAreRejected) {
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const DepthFrame wall = WallFrame(2.0);
  auto rejects = [&](auto change) {
    KinectNoiseOptions options;
    change(&options);
    EXPECT_THROW(ApplyKinectNoise(wall, camera, options, 1), InputError);
  };
  rejects([](KinectNoiseOptions* o) { o->baseline_m = 0; });
  rejects([](KinectNoiseOptions* o) { o->min_range_m = 5; });
  rejects([](KinectNoiseOptions* o) { o->max_incidence_deg = 120; });
  rejects([](KinectNoiseOptions* o) { o->edge_dropout_probability = 1.5; });
  rejects([](KinectNoiseOptions* o) { o->disparity_step_px = 0; });
  rejects([](KinectNoiseOptions* o) { o->noise_scale = 0; });
  rejects([](KinectNoiseOptions* o) { o->correlated_share = -0.1; });
  rejects([](KinectNoiseOptions* o) { o->correlation_radius_px = 0; });
  CameraIntrinsics smaller = camera;
  smaller.width = 320;
  smaller.cx = 159.5;
  EXPECT_THROW(ApplyKinectNoise(wall, smaller, KinectNoiseOptions{}, 1), InputError);
}

// The correlated field: unit variance everywhere (each value has a whole
// window), neighbours within a window correlated as the shared share of
// the window ((w - lag) / w along a row), none beyond it; the same seed the
// same field.
TEST(KinectNoise, CorrelatedFieldHasUnitVarianceAndItsWindowsCorrelation) {
  std::vector<float> field, scratch, again;
  const int width = 320, height = 240, radius = 4, window = 2 * radius + 1;
  CorrelatedNormalField(width, height, radius, 5, &field, &scratch);
  CorrelatedNormalField(width, height, radius, 5, &again, &scratch);
  EXPECT_EQ(field, again);
  double sum = 0, squares = 0;
  for (float x : field) sum += x, squares += static_cast<double>(x) * x;
  const double n = static_cast<double>(field.size());
  EXPECT_NEAR(sum / n, 0.0, 0.05);
  EXPECT_NEAR(squares / n, 1.0, 0.08);
  auto correlation = [&](int lag) {
    double product = 0;
    int64_t pairs = 0;
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u + lag < width; ++u) {
        product += static_cast<double>(field[v * width + u]) * field[v * width + u + lag];
        ++pairs;
      }
    }
    return product / pairs;
  };
  EXPECT_NEAR(correlation(1), (window - 1.0) / window, 0.05);
  EXPECT_NEAR(correlation(4), (window - 4.0) / window, 0.05);
  EXPECT_NEAR(correlation(window), 0.0, 0.04);
}

// noise_scale scales the axial sigma; a correlated share keeps each pixel's
// sigma but leaves little against the pixel's neighbours (a wall's pixels
// move together), and the same seed gives the same bytes.
TEST(KinectNoise, ScaledAndCorrelatedAxialNoise) {
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const DepthFrame wall = WallFrame(2.0);
  KinectNoiseOptions options = AllOff();
  options.axial_noise = true;
  auto errors = [&](const KinectNoiseOptions& o, double* neighbour_sd) {
    const DepthFrame noisy = ApplyKinectNoise(wall, camera, o, 3);
    std::vector<float> error, difference;
    for (int v = 100; v < 380; ++v) {
      for (int u = 100; u < 540; ++u) {
        const size_t i = static_cast<size_t>(v) * camera.width + u;
        error.push_back(static_cast<float>(noisy.depth[i] - wall.depth[i] + 1));  // > 0 for StdDev
        difference.push_back(static_cast<float>(noisy.depth[i] - noisy.depth[i + 1] -
                                                wall.depth[i] + wall.depth[i + 1] + 1));
      }
    }
    *neighbour_sd = StdDev(difference);
    return StdDev(error);
  };
  double white_neighbours = 0, half_neighbours = 0, correlated_neighbours = 0;
  const double white = errors(options, &white_neighbours);
  KinectNoiseOptions half = options;
  half.noise_scale = 0.5;
  EXPECT_NEAR(errors(half, &half_neighbours) / white, 0.5, 0.03);
  KinectNoiseOptions correlated = options;
  correlated.correlated_share = 0.9;
  const double correlated_sd = errors(correlated, &correlated_neighbours);
  EXPECT_NEAR(correlated_sd / white, 1.0, 0.1);
  // White: the difference of two pixels has sqrt(2) sigma; 90 % correlated
  // over 9 x 9: sqrt(2 (0.1 + 0.9 / 9)) sigma, about 0.63.
  EXPECT_NEAR(white_neighbours / white, std::sqrt(2.0), 0.05);
  EXPECT_LT(correlated_neighbours / correlated_sd, 0.75);
  const DepthFrame a = ApplyKinectNoise(wall, camera, correlated, 9);
  const DepthFrame b = ApplyKinectNoise(wall, camera, correlated, 9);
  EXPECT_EQ(std::memcmp(a.depth.data(), b.depth.data(), a.depth.size() * 4), 0);
}

}  // namespace
}  // namespace furn
