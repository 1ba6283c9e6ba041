// Options files: what trains a model and what detects, as one JSON document
//
//   {"trainer": {"preprocess": {...}, "region_growing": {...}, ...,
//                "scan": {...}},
//    "detector": {...}}
//
// written by `workbench tune` (best_options.json) and read by `train`,
// `detect` and `evaluate` with --options FILE: train reads "trainer", detect
// and evaluate read "detector"; a file may hold either or both. Absent keys
// keep their defaults; unknown keys, wrong types and values the options'
// Check() refuses are InputErrors naming the file and the key.
//
//   const TrainingOptions training = TrainingOptionsFromJson(text, "best.json");
//   TrainFromCatalog(catalog, training.scan, training.trainer, "model.fcm");
#pragma once

#include <string>

#include "core/codebook/trainer.h"
#include "core/detector/detector.h"

namespace furn {

struct TrainingOptions {
  TrainerOptions trainer;
  ScanOptions scan;
};

// The "trainer" object, every field present, keys in a fixed order (so equal
// options give equal text, which the model cache of `tune` hashes).
std::string TrainingOptionsJson(const TrainingOptions& options);

// Reads `text`: a whole options file (its "trainer" object, which must be
// there) or a bare trainer object.
TrainingOptions TrainingOptionsFromJson(const std::string& text, const std::string& what);

// Every detector option as JSON (stored with each run), and back: reads a
// whole options file or a run's options (their "detector" object; defaults
// when a file has only "trainer") or a bare detector object.
std::string DetectorOptionsJson(const DetectorOptions& options);
DetectorOptions DetectorOptionsFromJson(const std::string& text, const std::string& what);

// A whole options file: {"trainer": ..., "detector": ...}, pretty-printed.
std::string OptionsFileJson(const TrainingOptions& training, const DetectorOptions& detector);

}  // namespace furn
