#include "renderers/camera.h"

#include <gtest/gtest.h>

#include "core/util/error.h"
#include "tests/test_util.h"

namespace furn {
namespace {

TEST(Camera, KinectDefaultsFollowTheSpec) {
  const CameraIntrinsics kinect = CameraIntrinsics::KinectV1();
  EXPECT_EQ(kinect.width, 640);
  EXPECT_EQ(kinect.height, 480);
  EXPECT_DOUBLE_EQ(kinect.fx, 580);
  EXPECT_DOUBLE_EQ(kinect.cy, 239.5);
  EXPECT_NO_THROW(kinect.Check());
}

TEST(Camera, ProjectInvertsRayThroughPixel) {
  const CameraIntrinsics kinect = CameraIntrinsics::KinectV1();
  const Eigen::Vector3f ray = kinect.RayThroughPixel(100.25, 400.5);
  const Eigen::Vector2d pixel = kinect.Project(2.7 * ray.cast<double>());
  EXPECT_NEAR(pixel.x(), 100.25, 1e-4);
  EXPECT_NEAR(pixel.y(), 400.5, 1e-4);
  EXPECT_TRUE(kinect.RayThroughPixel(319.5, 239.5).isApprox(Eigen::Vector3f(0, 0, 1)));
}

TEST(Camera, BadIntrinsicsAreRejectedWithTheValue) {
  CameraIntrinsics camera;
  camera.fx = 0;
  try {
    camera.Check();
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("camera fx 0"), std::string::npos);
  }
  camera = CameraIntrinsics{};
  camera.width = -640;
  EXPECT_THROW(camera.Check(), InputError);
  camera = CameraIntrinsics{};
  camera.cx = 1000;
  EXPECT_THROW(camera.Check(), InputError);
  camera = CameraIntrinsics{};
  camera.fy = 1e30;  // accepted before, then "no floor found"
  EXPECT_NE(testing::ErrorOf([&] { camera.Check(); }).find("must be in (0, 100000] pixels"),
            std::string::npos);
}

}  // namespace
}  // namespace furn
