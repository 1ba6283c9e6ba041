// What detection says to people and programs: the detections of one scan as
// JSON (indented, or one line of a batch's JSON lines), a batch's error line,
// and the --explain text of every hypothesis.
//
//   std::printf("%s", DetectionJson(result, scan).c_str());
#pragma once

#include <string>

#include "core/detector.h"
#include "workbench/formats/scan_file.h"

namespace furn {

// Detections, pose used, timings, as JSON text: indented, or on one line
// (JSON lines of a batch).
std::string DetectionJson(const DetectionResult& result,
                          const LoadedScan& scan,
                          bool one_line = false);

// A JSON line for a scan of a batch that could not be detected in.
std::string ScanErrorJson(const std::string& input, const std::string& error);

// One detection for people: "chair     x   0.20  y   0.10  yaw  30.0 deg
// score 0.95  Scopia/chair3".
std::string DetectionLine(const Detection& d);

// Every hypothesis of a detection, one line each: class, place, vote weight,
// best fit and what became of it (the --explain text).
std::string ExplainDetection(const DetectionResult& result, const TrainedModel& model);

}  // namespace furn
