// Point cloud files: PCD and PLY read through PCL after our own header
// checks, and organised PCD written from a depth frame (camera frame, NaN
// where there is no return). Writers are atomic.
//
//   ScanCloud cloud = ReadPointCloudFile("scan.pcd");
//   WriteOrganizedPcd(frame, CameraIntrinsics::KinectV1(), "cloud.pcd");
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "renderers/camera.h"
#include "renderers/depth_frame.h"

namespace furn {

// A point cloud file: PCD or PLY (by extension), organised or not, with x, y,
// z fields of any numeric type (float, double, integers). Points are taken as
// they are (metres; their frame is the caller's to say).
struct ScanCloud {
  std::vector<Eigen::Vector3f> points;
  int width = 0, height = 0;  // organised size, or 0 x 0
  // The PCD header's VIEWPOINT (the sensor's pose in the cloud's frame) when
  // it is not the default (origin, identity).
  std::optional<Eigen::Isometry3d> viewpoint;
};
// Throws InputError naming the file when it is missing, unreadable, of
// another extension, or holds no x/y/z fields.
ScanCloud ReadPointCloudFile(const std::string& path);

// Our checks of a PCD or PLY file's header against its size, before PCL
// reads it (PCL trusts declared counts and sizes: crashes and huge
// allocations on damaged files). Throws InputError naming the file and the
// rule: field sizes, types and counts, WIDTH x HEIGHT = POINTS, at most 2^30
// points, a body that holds what the header declares, and a binary_compressed
// body whose sizes agree with it.
void CheckPcdHeader(const std::string& bytes, const std::string& path);
void CheckPlyHeader(const std::string& bytes, const std::string& path);

// An organized cloud of the frame's depth (metres; NaN where there is no
// return) as binary PCD: in the camera's optical frame, or, given the
// camera's pose, in the world with VIEWPOINT = that pose (PCL's
// sensor_origin_ and sensor_orientation_: the sensor in the cloud's frame,
// as ReadPointCloudFile and pcl_viewer take it). With the frame's instance
// ids, a `label` field per point (PCL's PointXYZL: the id the pixel shows,
// 0 for none).
void WriteOrganizedPcd(const DepthFrame& frame,
                       const CameraIntrinsics& camera,
                       const std::string& path,
                       const std::optional<Eigen::Isometry3d>& world_from_camera = std::nullopt);

}  // namespace furn
