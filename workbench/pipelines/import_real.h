// `dataset import-real`: a labelled real set (formats/real_labels.h) written
// into a dataset database, so that `evaluate`, `report`, `history` and
// `regress` treat real scans like generated frames.
//
//   RealSet set = ReadRealSet("data/real/labels.json");
//   ImportRealSet(set, "real.db", "sheets/");   // frames, labels, top-down sheets
#pragma once

#include <string>

#include "workbench/formats/real_labels.h"

namespace furn {

struct RealImportSummary {
  int frames = 0, objects = 0;
};

// Writes `db_path` anew (refused when it exists): one test-split room per
// scan, its depth re-projected through the scan's intrinsics (organised
// clouds keep their own; unorganised ones take Kinect v1's), its labels as
// objects, and the scans whose floor the detector must find recorded in the
// generation options. With `sheet_dir`, one top-down PNG per scan: the points
// in the label frame on a 0.5 m grid with the labelled footprints.
RealImportSummary ImportRealSet(const RealSet& set,
                                const std::string& db_path,
                                const std::string& sheet_dir = "");

}  // namespace furn
