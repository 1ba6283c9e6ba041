// A detection's REP 103 box in the world (conventions.h): what detect's
// JSON, the Python module and the bags' markers and Detection3DArray show.
//
//   const OrientedBox box = DetectionBoxInWorld(detection, detector.model());
#pragma once

#include "core/detector/detector.h"
#include "core/geometry/conventions.h"

namespace furn {

// The box of BoxOf (the learned footprint, else the fitted model's bounds),
// placed at the detection's reference point and yaw.
inline OrientedBox DetectionBoxInWorld(const Detection& detection, const TrainedModel& model) {
  const DetectionBox local = BoxOf(detection, model);
  return BoxInWorld(Eigen::Vector3d(detection.x, detection.y, detection.z),
                    detection.yaw,
                    local.low.cast<double>(),
                    local.high.cast<double>());
}

}  // namespace furn
