// What a run stores beside its metrics (RunRecord::results_json), as one
// typed record with one writer (Json) and one reader (Parse): an
// evaluation's PR curves, reliability bins, confusion counts and per-frame
// errors; a leave-models-out run's folds and pooled reliability bins.
//
//   RunResults results = RunResults::OfEvaluation(evaluation);
//   run.results_json = results.Json();
//   const RunResults read = RunResults::Parse(run.results_json, "synth.db run 3");
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "reports/evaluation.h"

namespace furn {

// One fold of a leave-models-out run.
struct FoldResult {
  int fold = 0;
  int64_t run = 0;                        // the fold's own evaluation run
  std::map<std::string, int> held_out;    // CAD models held out, per class name
  std::map<std::string, double> metrics;  // the fold's; NaN where it has none
};

struct RunResults {
  enum class Kind { kEvaluation, kCrossval };
  Kind kind = Kind::kEvaluation;
  // Evaluation: PR curves by name ("B/chair@10cm", "A/table"), each point
  // recall, precision, threshold.
  std::map<std::string, std::vector<PrPoint>> curves;
  // Both kinds (crossval: pooled over the folds); calibration_stored: the
  // run stored bins (runs older than that have none).
  std::vector<CalibrationBin> calibration;
  bool calibration_stored = true;
  // Evaluation: {detected class or "missed": {true class or "background":
  // count}}, detections at the operating point within 10 cm.
  // confusion_has_missed: the run counts missed objects in a "missed"
  // column (runs older than that have none).
  std::map<std::string, std::map<std::string, int>> confusion;
  bool confusion_has_missed = true;
  // Each object counted once (EvaluationResult::confusion); runs stored
  // before counted every kept detection in its cell. confusion_extra: the
  // kept detections left out (a second one on an object, on ignored ones).
  bool confusion_by_object = true;
  int confusion_extra = 0;
  // Evaluation: per frame id, false positives and missed objects at 10 cm.
  std::map<int64_t, std::pair<int, int>> frame_errors;
  // Crossval: its folds in order.
  std::vector<FoldResult> folds;

  // An evaluation's results (EvaluateFrames).
  static RunResults OfEvaluation(const EvaluationResult& result);
  // The stored JSON: the same record gives the same bytes.
  std::string Json() const;
  // A stored run's results, read as data anyone may have written: types
  // checked, one InputError naming `what` and the field otherwise.
  static RunResults Parse(const std::string& json, const std::string& what);
};

}  // namespace furn
