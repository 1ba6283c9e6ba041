// The one furniture box: where a piece stands on the floor, how it is
// turned and how large its footprint is. Every record of a piece of
// furniture embeds it (as its base), so a box passes between detection,
// decoding, training targets, ground truth and evaluation without
// field-by-field copies:
//
//   ScoredDetection scored;
//   scored.box() = detection.box();   // x, y, yaw, width, depth
//
// What each record adds (class, score, model, visibility) stays its own.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <optional>
#include <string>

#include "core/geometry/conventions.h"
#include "core/model/furniture_class.h"

namespace furn {

// The reference point (x, y: the footprint's centre on the floor, world
// frame, m), the CAD-model yaw about the world's z (radians; the model's
// front faces its -y, docs/cad-models.md) and the footprint (m) along the
// model's x (width, across the front) and y (depth, front to back); a size
// of 0 is unknown.
struct FurnitureBox {
  double x = 0, y = 0, yaw = 0;
  double width = 0, depth = 0;

  Eigen::Vector2d Centre() const { return {x, y}; }
  void SetCentre(const Eigen::Vector2d& xy) { x = xy.x(), y = xy.y(); }

  FurnitureBox& box() { return *this; }
  const FurnitureBox& box() const { return *this; }
};

// The box moved from one floor frame to another (to_from_from: the target
// floor frame from the box's; z is ignored): its reference point and yaw
// move, its footprint stays.
inline FurnitureBox MovedBox(FurnitureBox box, const Eigen::Isometry3d& to_from_from) {
  const Eigen::Vector3d p = to_from_from * Eigen::Vector3d(box.x, box.y, 0);
  const Eigen::Vector3d heading = to_from_from.linear() * Eigen::Vector3d(1, 0, 0);
  box.x = p.x();
  box.y = p.y();
  box.yaw += std::atan2(heading.y(), heading.x());
  return box;
}

// The 3-D world box (REP 103: its x the piece's front) of the footprint,
// standing at height `z`, `height` tall.
inline OrientedBox WorldBoxOf(const FurnitureBox& box, double z, double height) {
  return FootprintBoxInWorld(
      Eigen::Vector3d(box.x, box.y, z), box.yaw, box.width, box.depth, height);
}

// A labelled piece as a scan's ground truth carries it (dataset frames,
// real-scan labels): the box in the scan's world frame, its height, its class
// (none: clutter) and, where known, its CAD model and visibility.
struct GroundTruthFootprint : FurnitureBox {
  std::optional<FurnitureClass> furniture_class;  // none for clutter
  double height = 0;
  std::string model_id;    // empty: not known
  double visibility = -1;  // visible / amodal pixels in this frame; -1: not known
};

}  // namespace furn
