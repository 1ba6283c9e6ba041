// How much of a box the sensor's image covers: a detection cut by the
// image's side has its centre guessed from the part in view (issue 37
// measured tables cut by the frame 13.7 cm off against 4.9 cm whole), so
// every detection carries this share (Detection::in_view) and evaluation
// computes the same share for the ground truth (--min-in-view).
//
//   const ViewFrustum view = ViewFrustum::OfPinhole(intrinsics, 640, 480);
//   double share = ShareOfBoxInView(view, camera_from_box, low, high);  // 0..1
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace furn {

struct PinholeIntrinsics;

// A camera's view as bounds on a camera-frame point's tangents (optical
// frame: x right, y down, z forward): in view when z > 0 and x / z, y / z
// lie within them.
struct ViewFrustum {
  // x / z in [left, right), y / z in [top, bottom).
  double left = 0, right = 0, top = 0, bottom = 0;

  // The image of `width` x `height` pixels: pixel centres -0.5 .. width - 0.5.
  static ViewFrustum OfPinhole(const PinholeIntrinsics& intrinsics, int width, int height);
  // The tangent span of the finite points in front of the camera (a scan
  // that is not an organised image); nullopt with fewer than two.
  static std::optional<ViewFrustum> OfPoints(const std::vector<Eigen::Vector3f>& points);

  bool Contains(const Eigen::Vector3d& point_in_camera) const;
};

// Of 8 x 8 x 4 points spread through the box (its own frame, low..high),
// the share the view contains; a box wholly in view gives 1, a box centred
// on the image's side about 0.5, one behind the camera 0.
double ShareOfBoxInView(const ViewFrustum& view,
                        const Eigen::Isometry3d& camera_from_box,
                        const Eigen::Vector3d& low,
                        const Eigen::Vector3d& high);

}  // namespace furn
