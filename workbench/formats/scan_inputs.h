// The scans a batch names: files, globs, TUM RGB-D lists and BOP folders,
// expanded into one ScanSource each.
//
//   std::vector<ScanSource> sources = ExpandScanInputs({"scans/*.pcd"}, common, false, false);
#pragma once

#include <string>
#include <vector>

#include "workbench/formats/scan_file.h"

namespace furn {

// The scans behind `inputs`, each a file (.pcd/.ply: cloud; .png/.tif/.tiff/
// .exr: depth image), a glob pattern of such files, a TUM RGB-D list (.txt:
// depth.txt or associate.py's output; its depth images with TUM's depth
// scale 5000 and intrinsics 525,525,319.5,239.5 unless `common` sets them),
// or a BOP scene or split folder (depth/*.png with scene_camera.json), in
// order. Every source copies `common`'s options. Throws InputError naming the
// input that matches nothing or is of no known kind.
std::vector<ScanSource> ExpandScanInputs(const std::vector<std::string>& inputs,
                                         const ScanSource& common,
                                         bool intrinsics_given,
                                         bool depth_scale_given);

}  // namespace furn
