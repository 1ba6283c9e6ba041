// `workbench evaluate`: detection over the frames of a dataset split (both
// cores per frame, a progress bar), protocols A and B (reports/evaluation.h),
// and one run stored in the dataset: git commit and dirty flag, time, model
// and dataset hashes, every option, detections, per-frame stage timings,
// metrics, PR curves and confusion. `workbench regress` compares a run's
// metrics with a baseline (another run or a JSON file).
//
//   EvaluateCommandOptions options;
//   options.split = Split::kTest;
//   EvaluateSummary summary = EvaluateModel("model.fcm", "synth.db", options);
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/detector/detector.h"
#include "db/dataset_db.h"  // RunRecord
#include "reports/evaluation.h"
#include "workbench/formats/options_file.h"  // DetectorOptionsJson, DetectorOptionsFromJson
#include "workbench/formats/scan_file.h"     // FrameFusion

namespace furn {

struct EvaluateCommandOptions {
  Split split = Split::kTest;
  int max_frames = 0;  // 0: every frame of the split
  std::string label;   // free text stored with the run
  std::string kind = "evaluate";
  // A JSON object whose members join the run's stored options (tune puts its
  // id, trial and parameters here); "" for none.
  std::string extra_options_json;
  // Only rooms k with k % fold_count == fold (a leave-models-out fold); off
  // when fold_count is 0.
  int fold = 0;
  int fold_count = 0;
  DetectorOptions detector;
  EvaluationOptions evaluation;
  // The operating point's match distance (m) for the op/ metrics; 0: the
  // model's (20 cm). Real sets labelled by visible-part centres are scored
  // at 0.5 m (docs/real-scans.md).
  double op_match_m = 0;
  // Each frame detected with the other frames of its room fused in (their
  // known poses, optionally with a random error), seen from its own camera;
  // its ground truth is unchanged. Off: protocol E is one frame.
  FrameFusion fusion;
  // Keep every fitted hypothesis that passed the scorer's gates, labelled by
  // the ground truth, for training a hypothesis scorer.
  bool collect_scorer_samples = false;
  // A shard of the evaluation (issue 31): only the selected frames at
  // positions p with p % shard_count == shard_index, written to shard_out
  // (see evaluated_frame.h) instead of a run; off when shard_count is 0.
  int shard_index = 0;
  int shard_count = 0;
  std::string shard_out;
  // MergeEvaluation only reads and checks the shards (every header against
  // this evaluation), storing nothing.
  bool check_only = false;
  // The run's detections (every candidate, in the labels' frame) also
  // written to this file in the external detections format
  // (workbench/formats/external_detections.h); "" for none.
  std::string write_detections;
};

struct EvaluateSummary {
  int64_t run_id = 0;  // 0 for a shard: no run stored
  EvaluationResult result;
  int frames = 0;
  int frames_without_points = 0;  // no point in range: counted, with no detections
  int frames_without_floor = 0;   // no pose and no floor found: likewise
  double seconds = 0;
  bool already_stored = false;  // a merge found its run stored by an earlier attempt
  // With collect_scorer_samples: positive when the fit lies within 10 cm of
  // a true object of its class.
  std::vector<ScorerSample> scorer_samples;
};

// Throws InputError for a missing model or dataset, or a split with no frames.
EvaluateSummary EvaluateModel(const std::string& model_path,
                              const std::string& db_path,
                              const EvaluateCommandOptions& options);

// A run of detections another program wrote for the frames of the dataset
// (ReadExternalDetections: a file or a directory), scored and stored exactly
// as EvaluateModel's: every metric, curve and detection; latency only when
// every frame gives its time. Runs of kind "external"; the operating point
// is options.detector's --min-score (none: every detection kept). Throws
// InputError naming the file and line for a malformed file, a frame of the
// selection without a line, or a frame the dataset does not have.
EvaluateSummary EvaluateDetections(const std::string& detections_path,
                                   const std::string& db_path,
                                   const EvaluateCommandOptions& options);

// The run EvaluateModel would store, from the shard files of shards 0..N-1
// (in that order) of the same evaluation: metrics, curves and detections
// equal to one process's, only the timings are the tasks'. Throws InputError
// naming the file for a missing shard, or one of another dataset, split,
// model, option set or shard count.
EvaluateSummary MergeEvaluation(const std::string& model_path,
                                const std::string& db_path,
                                const EvaluateCommandOptions& options,
                                const std::vector<std::string>& shard_paths);

// Detection by `model` with every candidate over the selected frames
// (options' split, max_frames), and the operating point of best F1 per class
// there (ChooseOperatingPoint at kOperatingMatchM). Stores no run.
OperatingPoint ChooseOperatingPointOn(const TrainedModel& model,
                                      const std::string& db_path,
                                      const EvaluateCommandOptions& options);

// The share of an object's 3-D box in the frame's view (TruthObject::in_view):
// of a regular grid of points inside the box, those in front of the camera
// that project into the image.
double ShareInView(const ObjectRecord& object, const FrameRecord& frame);

// Rotational symmetry order (4, 2 or 1) of a model shape about its origin:
// the largest order whose rotation maps 90 % of its points onto itself.
int SymmetryOrder(const ModelShape& shape);

}  // namespace furn
