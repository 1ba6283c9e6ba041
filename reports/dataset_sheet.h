// Contact sheet of dataset frames for people: each tile is a frame's noisy
// depth (colourised; black = no return) with the ground-truth boxes of the
// detection targets and their class and visibility. Targets at least
// `min_visibility` visible are drawn in colour, the others in grey.
//
//   WriteDatasetSheet(frames_with_objects, DatasetSheetOptions{}, "sheet.png");
#pragma once

#include <string>
#include <vector>

#include "db/dataset_db.h"

namespace furn {

struct DatasetSheetOptions {
  int columns = 4;               // tiles per row (>= 1)
  double scale = 0.5;            // tile size relative to the frame (0.1..1)
  double min_visibility = 0.25;  // drawn in colour at or above this
  bool Check() const { return columns >= 1 && scale >= 0.1 && scale <= 1 && min_visibility >= 0; }
};

struct SheetFrame {
  const FrameRecord* frame = nullptr;  // with images
  const RoomRecord* room = nullptr;    // for the objects' classes
};

// Throws InputError for bad options, no frames, or an unwritable path.
void WriteDatasetSheet(const std::vector<SheetFrame>& frames,
                       const DatasetSheetOptions& options,
                       const std::string& png_path);

}  // namespace furn
