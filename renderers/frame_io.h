// Files of depth frames: 16-bit PNG depth in millimetres (TUM/BOP convention,
// 0 = no return), 16-bit PNG instance ids, organized PCD (PCL, camera frame,
// NaN where there is no return), and a colourised preview for people.
// Every writer is atomic: a failed write leaves no file behind.
//
//   WriteDepthPng(frame, "depth.png");                 // 1 unit = 1 mm
//   DepthFrame back = ReadDepthPng("depth.png", 1000);  // depth only
//   WriteOrganizedPcd(frame, CameraIntrinsics::KinectV1(), "cloud.pcd");
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "renderers/camera.h"
#include "renderers/depth_frame.h"

namespace furn {

// units_per_metre: 1000 for our data (mm), 5000 for TUM RGB-D.
void WriteDepthPng(const DepthFrame& frame, const std::string& path, double units_per_metre = 1000);
// Throws InputError when the file is not a single-channel 16-bit PNG.
DepthFrame ReadDepthPng(const std::string& path, double units_per_metre = 1000);
// A depth image of any kind a depth sensor's tools write: 16-bit PNG (units
// per metre as above), 16-bit or 32-bit float TIFF, or 32-bit float OpenEXR.
// Float images hold metres unless `units_per_metre` is given; integer images
// default to millimetres. Non-finite or non-positive depth: no return.
// Throws InputError naming the file for other formats or channel counts.
DepthFrame ReadDepthImage(const std::string& path, std::optional<double> units_per_metre);
void WriteIdPng(const DepthFrame& frame, const std::string& path);
// An 8-bit single-channel PNG of `mask` (row-major, width x height), e.g. 0
// and 255 for a BOP object mask.
void WriteMaskPng(const std::vector<uint8_t>& mask, int width, int height, const std::string& path);
void WriteOrganizedPcd(const DepthFrame& frame,
                       const CameraIntrinsics& camera,
                       const std::string& path);

// The same images as bytes (PNG, zlib level 1: fast, for database BLOBs), and back.
std::vector<uint8_t> EncodeDepthPng(const DepthFrame& frame, double units_per_metre = 1000);
std::vector<uint8_t> EncodeIdPng(const DepthFrame& frame);
// Throws InputError naming `what` when the bytes are not a 16-bit single-channel PNG.
DepthFrame DecodeDepthPng(const std::vector<uint8_t>& png,
                          const std::string& what,
                          double units_per_metre = 1000);
// Fills instance_ids of `frame` (which must have the image's size).
void DecodeIdPng(const std::vector<uint8_t>& png, const std::string& what, DepthFrame* frame);

// Camera-frame points of a depth frame, one per pixel in row order (an
// organised cloud), NaN where there is no return.
std::vector<Eigen::Vector3f> BackProject(const DepthFrame& frame, const CameraIntrinsics& camera);

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

struct PreviewPanel {
  enum class Kind { kDepth, kShadedDepth, kIds };
  const DepthFrame* frame = nullptr;
  Kind kind = Kind::kDepth;
  std::string title;
};

// Panels in a grid (`columns` wide) with titles. Depth panels share one colour
// range (the 1st..99th percentile of the first depth panel); shaded panels
// light the surface from its depth gradient, which shows noise and banding.
void WritePreviewPng(const std::vector<PreviewPanel>& panels, int columns, const std::string& path);

}  // namespace furn
