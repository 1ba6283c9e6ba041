// The share of a box inside a camera's view (Detection::in_view and the
// ground truth's --min-in-view).
#include "core/geometry/view_share.h"

#include <gtest/gtest.h>

#include "core/geometry/render_compare.h"  // PinholeIntrinsics

namespace furn {
namespace {

// Kinect v1: 640 x 480, f 580, principal point at the image's centre.
ViewFrustum Kinect() { return ViewFrustum::OfPinhole({580, 580, 319.5, 239.5}, 640, 480); }

Eigen::Isometry3d At(double x, double y, double z) {
  return Eigen::Isometry3d(Eigen::Translation3d(x, y, z));
}

TEST(ViewFrustum, PinholeBoundsAreTheImagesOuterPixelEdges) {
  const ViewFrustum view = Kinect();
  EXPECT_DOUBLE_EQ(view.left, -320.0 / 580);
  EXPECT_DOUBLE_EQ(view.right, 320.0 / 580);
  EXPECT_DOUBLE_EQ(view.top, -240.0 / 580);
  EXPECT_DOUBLE_EQ(view.bottom, 240.0 / 580);
  EXPECT_TRUE(view.Contains({0, 0, 1}));
  EXPECT_TRUE(view.Contains({-0.55, 0, 1}));  // just inside the left edge
  EXPECT_FALSE(view.Contains({0.56, 0, 1}));  // beyond the right edge
  EXPECT_FALSE(view.Contains({0, 0.42, 1}));  // below the bottom
  EXPECT_FALSE(view.Contains({0, 0, -1}));    // behind the camera
  EXPECT_FALSE(view.Contains({0, 0, 0}));
}

TEST(ViewFrustum, OfPointsIsTheirTangentSpanWithTheExtremesInside) {
  const std::vector<Eigen::Vector3f> points = {
      {-1, 0.5f, 2},                                     // u -0.5, v 0.25
      {2, -1, 4},                                        // u 0.5, v -0.25
      {0, 0, -1},                                        // behind: ignored
      {std::numeric_limits<float>::quiet_NaN(), 0, 1}};  // not finite: ignored
  const std::optional<ViewFrustum> view = ViewFrustum::OfPoints(points);
  ASSERT_TRUE(view);
  EXPECT_DOUBLE_EQ(view->left, -0.5);
  EXPECT_NEAR(view->right, 0.5, 1e-12);
  EXPECT_TRUE(view->Contains({-1, 0.5, 2}));
  EXPECT_TRUE(view->Contains({2, -1, 4}));
  EXPECT_FALSE(view->Contains({1.1, 0, 2}));
  EXPECT_FALSE(ViewFrustum::OfPoints({{0, 0, 1}}));  // one point spans nothing
  EXPECT_FALSE(ViewFrustum::OfPoints({}));
}

TEST(ShareOfBoxInView, WholeHalfNoneAndBehind) {
  const ViewFrustum view = Kinect();
  const Eigen::Vector3d low(-0.4, -0.3, -0.2), high(0.4, 0.3, 0.2);
  EXPECT_DOUBLE_EQ(ShareOfBoxInView(view, At(0, 0, 3), low, high), 1.0);
  // Centred on the right edge at 3 m: x = 3 * 320 / 580.
  EXPECT_NEAR(ShareOfBoxInView(view, At(3 * 320.0 / 580, 0, 3), low, high), 0.5, 0.07);
  EXPECT_DOUBLE_EQ(ShareOfBoxInView(view, At(4, 0, 3), low, high), 0.0);   // beyond the side
  EXPECT_DOUBLE_EQ(ShareOfBoxInView(view, At(0, 0, -3), low, high), 0.0);  // behind
  // The box's own frame turns with it: a long box turned to lie across the
  // image's right edge.
  const Eigen::Isometry3d turned =
      At(3 * 320.0 / 580, 0, 3) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY());
  EXPECT_NEAR(ShareOfBoxInView(view, turned, {-0.05, -0.3, -1.0}, {0.05, 0.3, 1.0}), 0.5, 0.1);
}

}  // namespace
}  // namespace furn
