// The conventions of everything the workbench hands to people and programs
// (docs/conventions.md): SI units, radians, REP 103 axes. The world frame has
// the floor at z = 0 and z up. A detection or a label is an oriented 3-D box
// whose own x axis is the object's front (REP 103: x forward, y left, z up);
// its yaw is the angle of that axis from the world's x axis, counterclockwise,
// in (-pi, pi].
//
// Inside, the engine keeps CAD-model poses, whose front is the catalogs' -y
// (SPEC §4, the dataset database, BOP export): the functions here are the one
// place that turns one into the other.
//
//   const OrientedBox box = DetectionBoxInWorld(detection, model);  // detection_box.h
//   json["yaw"] = box.yaw;  json["quaternion"] = QuaternionXyzw(box.yaw);
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cmath>

namespace furn {

// An angle in (-pi, pi].
inline double WrapToPi(double radians) {
  double wrapped = std::remainder(radians, 2 * M_PI);  // [-pi, pi]
  if (wrapped <= -M_PI) wrapped += 2 * M_PI;
  return wrapped;
}

// The REP 103 yaw (front along x) of a CAD-model yaw (front along -y): the
// front R(model_yaw) (0, -1) = (cos, sin) of model_yaw - pi/2.
inline double Rep103YawFromModelYaw(double model_yaw) { return WrapToPi(model_yaw - M_PI / 2); }
inline double ModelYawFromRep103Yaw(double yaw) { return WrapToPi(yaw + M_PI / 2); }

// A box in the world: centre (m), size along its own x (front), y (left) and
// z (m), yaw of its x axis about the world's z (REP 103, radians).
struct OrientedBox {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  double yaw = 0;
};

// The world box of an object placed at `reference` (its floor point) with a
// CAD-model yaw, whose bounds in the model's own frame are low..high (x
// across the front, y front to back (front -y), z up from the reference).
inline OrientedBox BoxInWorld(const Eigen::Vector3d& reference,
                              double model_yaw,
                              const Eigen::Vector3d& low,
                              const Eigen::Vector3d& high) {
  OrientedBox box;
  const Eigen::Vector3d middle = (low + high) / 2;
  box.centre = reference + Eigen::AngleAxisd(model_yaw, Eigen::Vector3d::UnitZ()) * middle;
  box.size = Eigen::Vector3d(high.y() - low.y(), high.x() - low.x(), high.z() - low.z());
  box.yaw = Rep103YawFromModelYaw(model_yaw);
  return box;
}

// The box of a footprint width x depth (across the front, front to back)
// centred on `reference` on the floor, `height` tall, turned by a CAD-model yaw.
inline OrientedBox FootprintBoxInWorld(
    const Eigen::Vector3d& reference, double model_yaw, double width, double depth, double height) {
  return BoxInWorld(reference,
                    model_yaw,
                    Eigen::Vector3d(-width / 2, -depth / 2, 0),
                    Eigen::Vector3d(width / 2, depth / 2, height));
}

// The box's own frame in the world: its centre, x along its front.
inline Eigen::Isometry3d WorldFromBox(const OrientedBox& box) {
  Eigen::Isometry3d world_from_box = Eigen::Isometry3d::Identity();
  world_from_box.translation() = box.centre;
  world_from_box.linear() = Eigen::AngleAxisd(box.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return world_from_box;
}

// The rotation about z by `yaw` as a quaternion x, y, z, w (ROS order).
inline std::array<double, 4> QuaternionXyzw(double yaw) {
  return {0.0, 0.0, std::sin(yaw / 2), std::cos(yaw / 2)};
}

// A pose as its four rows (the order people write a matrix in; numpy's
// np.array(rows)).
inline std::array<std::array<double, 4>, 4> PoseRows(const Eigen::Isometry3d& pose) {
  std::array<std::array<double, 4>, 4> rows{};
  const Eigen::Matrix4d m = pose.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) rows[r][c] = m(r, c);
  }
  return rows;
}

}  // namespace furn
