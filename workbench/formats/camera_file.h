// Camera descriptions as depth datasets ship them, and sensor poses as
// people type them.
//
//   CameraFile file = ReadCameraFile("scene_camera.json", /*image_id=*/42);
//   Eigen::Isometry3d pose = ParsePose("1.2,0,1.1,1,0,0,0");
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "renderers/camera.h"

namespace furn {

struct CameraFile {
  // fx, fy, cx, cy; width and height are 0 when the file does not give them
  // (the depth image's size applies).
  CameraIntrinsics camera;
  // Depth units per metre when the file says (BOP's depth_scale).
  std::optional<double> units_per_metre;
};

// Reads, by content:
//   - BOP camera.json: {"fx", "fy", "cx", "cy", "width", "height", "depth_scale"};
//   - BOP scene_camera.json: {"<image id>": {"cam_K": [9 numbers], "depth_scale"}},
//     the entry `image_id` (required);
//   - ROS CameraInfo YAML, either camera_calibration's file (image_width,
//     image_height, camera_matrix: {data: [9]}) or a message dump (width,
//     height, K or k: [9]).
// BOP's depth_scale is millimetres per unit (units per metre = 1000 /
// depth_scale). Throws InputError naming the file and the missing or bad key.
CameraFile ReadCameraFile(const std::string& path, std::optional<int64_t> image_id = std::nullopt);

// The one check of a camera matrix from any source (camera files, ROS
// CameraInfo, Python): K = [fx, 0, cx, 0, fy, cy, 0, 0, 1] (9 numbers, row by
// row; a skewed K is refused), then CameraIntrinsics::Check when the size is
// known (width and height > 0). Throws InputError naming `where`.
CameraIntrinsics CameraFromMatrix(const std::vector<double>& k,
                                  int width,
                                  int height,
                                  const std::string& where);

// Depth units per metre from a camera file, flag or message: in [1, 10^6]
// (1: metres, 1000: millimetres, 5000: TUM). Throws InputError naming `what`.
void CheckUnitsPerMetre(double units_per_metre, const std::string& what);

// A pose as 16 numbers (a 4x4 matrix, row by row, separated by commas or
// spaces; the last row 0 0 0 1) or as "t=x,y,z q=qx,qy,qz,qw" (translation
// and quaternion x,y,z,w as ROS and Eigen's coeffs(); the parts apart by a
// space or ';'). Throws InputError naming `what` for another count, seven
// bare numbers (once x,y,z,qw,qx,qy,qz: refused, not guessed), a non-number,
// a non-rigid matrix or a quaternion far from unit length.
Eigen::Isometry3d ParsePose(const std::string& text, const std::string& what);

// x,y,z (metres). Throws InputError naming `what`.
Eigen::Vector3d ParsePosition(const std::string& text, const std::string& what);

}  // namespace furn
