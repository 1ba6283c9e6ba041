// Detections from the learned vote map (issue 30): per class, the heat
// map's local maxima (3 x 3) of at least min_heat, the strongest
// max_per_class of each; then over all classes, strongest first, a maximum
// within suppress_m of a stronger kept one is suppressed (one piece of
// furniture, one label). Each keeps the network's sub-cell position, yaw
// (modulo its class's symmetry, in the world frame) and footprint.
//
//   for (const BevPeak& p : DecodeBevOutput(image, output, BevDecodeOptions{})) ...
#pragma once

#include <vector>

#include "core/bev_grid.h"
#include "core/vote_net.h"

namespace furn {

struct BevDecodeOptions {
  double min_heat = 0.1;
  int max_per_class = 16;
  double suppress_m = 0.3;
};

struct BevPeak {
  FurnitureClass furniture_class = FurnitureClass::kChair;
  double x = 0, y = 0, yaw = 0;  // world frame
  double width = 0, depth = 0;   // footprint (m)
  double heat = 0;
  bool suppressed = false;
  double suppressed_by_m = 0;  // distance to the stronger maximum, when suppressed
};

// Strongest first; suppressed maxima are kept in the list, marked.
std::vector<BevPeak> DecodeBevOutput(const BevImage& image,
                                     const BevOutput& output,
                                     const BevDecodeOptions& options);

}  // namespace furn
