// Top-down sheet of one labelled real scan: its points seen from above in
// the labels' floor frame, on a metric grid, with the labelled footprints,
// so labels can be made and checked by eye.
//
//   WriteRealScanSheet(points, world_from_camera, camera, labels, "tum-fr2-desk",
//   "sheets/tum.png");
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "renderers/camera.h"
#include "reports/detection_debug.h"

namespace furn {

// `points`: floor frame (z up, floor at 0), seen by `camera` at
// `world_from_camera`; a label whose yaw is NaN has no front and is drawn
// as a circle. Labels need `height` for the camera view's boxes.
void WriteRealScanSheet(const std::vector<Eigen::Vector3f>& points,
                        const Eigen::Isometry3d& world_from_camera,
                        const CameraIntrinsics& camera,
                        const std::vector<GroundTruthFootprint>& labels,
                        const std::string& title,
                        const std::string& png_path);

}  // namespace furn
