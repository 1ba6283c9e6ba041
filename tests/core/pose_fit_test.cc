// The 3-DOF transform of a point pair and the pose fit over the whole circle of yaws, on analytic
// shapes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/geometry/pose_fit.h"
#include "core/util/random.h"
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

}  // namespace
}  // namespace furn
