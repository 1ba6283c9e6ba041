// Pinhole camera model shared by the OSMesa renderer and the Embree ray
// caster. Camera frame is optical: x right, y down, z forward; pixel (u, v)
// has its centre at integer coordinates.
//
//   CameraIntrinsics kinect = CameraIntrinsics::KinectV1();  // 640x480, f =
//   580 kinect.Check();                                          // throws on
//   bad values Eigen::Vector3f ray = kinect.RayThroughPixel(319.5, 239.5);  //
//   (0, 0, 1)
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "renderers/depth_frame.h"

namespace furn {

struct CameraIntrinsics {
  int width = 640;    // pixels
  int height = 480;   // pixels
  double fx = 580.0;  // focal length, pixels
  double fy = 580.0;  // focal length, pixels
  double cx = 319.5;  // principal point, pixels
  double cy = 239.5;  // principal point, pixels

  static CameraIntrinsics KinectV1() { return CameraIntrinsics{}; }

  // Throws InputError naming the value and the rule: sizes in 1..16384,
  // focal lengths > 0 and finite, principal point inside the image.
  void Check() const;

  // Direction (not normalised, z = 1) of the ray through pixel (u, v).
  Eigen::Vector3f RayThroughPixel(double u, double v) const {
    return Eigen::Vector3f(
        static_cast<float>((u - cx) / fx), static_cast<float>((v - cy) / fy), 1.0f);
  }

  // Pixel of a camera-frame point in front of the camera (z > 0).
  Eigen::Vector2d Project(const Eigen::Vector3d& point_in_camera) const {
    return Eigen::Vector2d(fx * point_in_camera.x() / point_in_camera.z() + cx,
                           fy * point_in_camera.y() / point_in_camera.z() + cy);
  }

  std::string ToString() const;
};

// Camera-frame points of a depth frame, one per pixel in row order (an
// organised cloud), NaN where there is no return.
std::vector<Eigen::Vector3f> BackProject(const DepthFrame& frame, const CameraIntrinsics& camera);

}  // namespace furn
