// A colourised preview of depth frames for people: depth, shaded depth and
// instance-id panels in a grid with titles.
//
//   WritePreviewPng({{&frame, PreviewPanel::Kind::kDepth, "noisy"}}, 1, "preview.png");
#pragma once

#include <string>
#include <vector>

#include "renderers/depth_frame.h"

namespace furn {

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
