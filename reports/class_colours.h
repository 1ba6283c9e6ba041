// The colour of each detector class in every figure and marker: reports'
// PNGs, and RViz markers of detections and ground truth. No OpenCV here, so
// layers above reports can use it.
//
//   const std::array<uint8_t, 3> rgb = ClassColourRgb(FurnitureClass::kChair);
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "core/model/furniture_class.h"

namespace furn {

// Red, green, blue of a class; white for none (clutter).
std::array<uint8_t, 3> ClassColourRgb(std::optional<FurnitureClass> furniture_class);

}  // namespace furn
