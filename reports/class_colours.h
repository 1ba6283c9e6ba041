// The colour of each detector class in every figure and marker: reports'
// PNGs, and RViz markers of detections and ground truth. No OpenCV here, so
// layers above reports can use it.
//
//   const std::array<uint8_t, 3> rgb = ClassColourRgb("chair");
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace furn {

// Red, green, blue of a class name; white for anything else (clutter).
std::array<uint8_t, 3> ClassColourRgb(const std::string& class_name);

}  // namespace furn
