// Depth and label images: 16-bit PNG depth in millimetres (TUM/BOP
// convention, 0 = no return), 16-bit PNG instance ids, 8-bit masks, and the
// depth images other tools write (16-bit or float TIFF, float OpenEXR).
// Every writer is atomic: a failed write leaves no file behind.
//
//   WriteDepthPng(frame, "depth.png");                 // 1 unit = 1 mm
//   DepthFrame back = ReadDepthPng("depth.png", 1000);  // depth only
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "renderers/depth_frame.h"

namespace furn {

// The most pixels one depth frame may have (PNG, ROS image): a detection
// costs some 70 bytes a pixel, so 4096 x 4096 (16.8 M, 55 Kinect v1 frames)
// stays near 1 GB.
inline constexpr uint64_t kMaxDepthPixels = uint64_t{1} << 24;

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
// The same images as bytes (PNG, zlib level 1: fast, for database BLOBs), and back.
std::vector<uint8_t> EncodeDepthPng(const DepthFrame& frame, double units_per_metre = 1000);
std::vector<uint8_t> EncodeIdPng(const DepthFrame& frame);
// Throws InputError naming `what` when the bytes are not a 16-bit single-channel PNG.
DepthFrame DecodeDepthPng(const std::vector<uint8_t>& png,
                          const std::string& what,
                          double units_per_metre = 1000);
// Fills instance_ids of `frame` (which must have the image's size).
void DecodeIdPng(const std::vector<uint8_t>& png, const std::string& what, DepthFrame* frame);

}  // namespace furn
