// What detection says to people and programs: the detections of one scan as
// JSON (indented, or one line of a batch's JSON lines), a batch's error line,
// and the --explain text of every hypothesis.
//
//   std::printf("%s", DetectionJson(result, scan).c_str());
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/detector/detector.h"
#include "workbench/formats/scan_file.h"

namespace furn {

// The detection JSON's format. 2 (this one): poses as four rows, each
// detection a REP 103 box (centre, size, yaw, quaternion), model and
// verification null when there was no fit. 1 had a column-major pose and
// the CAD model's x, y, z, yaw (front -y). docs/conventions.md.
inline constexpr int kDetectionJsonFormat = 2;
inline constexpr const char* kConventionsText =
    "SI units, radians; world: floor at z = 0, z up; boxes REP 103 (x = the object's front, "
    "yaw of x about z in (-pi, pi], quaternion x, y, z, w); poses as 4 rows "
    "(docs/conventions.md)";

// One detection as its JSON object (REP 103 box, docs/conventions.md).
nlohmann::ordered_json DetectionBoxJson(const Detection& detection, const TrainedModel& model);

// What made a detection: the model file (its path and content hash, as
// evaluation runs store it); the program's version is the build's.
struct DetectionProvenance {
  std::string model_path;
  std::string model_hash;
};

// Detections, pose used, camera, program and model, timings, as JSON text:
// indented, or on one line (JSON lines of a batch).
std::string DetectionJson(const DetectionResult& result,
                          const LoadedScan& scan,
                          const TrainedModel& model,
                          const DetectionProvenance& provenance,
                          bool one_line = false);

// A JSON line for a scan of a batch that could not be detected in.
std::string ScanErrorJson(const std::string& input, const std::string& error);

// One detection for people: "chair     x   0.20  y   0.10  yaw   30.0 deg
// score 0.95  Scopia/chair3  footprint 0.55 x 0.50 m" (REP 103 yaw; the
// footprint along the front, then across; the model only when fitted).
std::string DetectionLine(const Detection& d);

// Every hypothesis of a detection, one line each: class, place, vote weight,
// best fit and what became of it (the --explain text).
std::string ExplainDetection(const DetectionResult& result, const TrainedModel& model);

}  // namespace furn
