// What the evaluation of one frame adds to a run, and the shard file that
// carries such frames between the tasks of a sharded `evaluate` (issue 31)
// and the step that merges them into one run.
//
// A shard file is JSON: a header that says which evaluation it belongs to
// (shard i of N, the hash of the frames of the whole selection, the model's
// hash, the run's stored options) and, per frame it evaluated, its position
// in the selection, the detector's status, detections, maxima and timings.
// The ground truth is not in it: the merge reads it from the dataset.
// Doubles are written so that they read back to the same bits.
//
//   WriteShardFile(path, header, frames);
//   const std::vector<EvaluatedFrame> frames = ReadShardFile(path, expected_header);
#pragma once

#include <string>
#include <vector>

#include "core/codebook/hypothesis_scorer.h"  // ScorerSample
#include "core/detector/detector.h"
#include "db/dataset_db.h"       // RunDetectionRecord, RunFrameRecord
#include "reports/evaluation.h"  // FrameOutcome

namespace furn {

// A detection as evaluation scores it; `symmetry` is the rotational order of
// its model (a learned detection names none: its class's, BevYawSymmetry).
ScoredDetection ScoredDetectionOf(const Detection& d, int symmetry);

struct EvaluatedFrame {
  int position = 0;  // in the selection of frames (split, fold, max_frames)
  DetectionStatus status = DetectionStatus::kDetected;
  FrameOutcome outcome;  // in a shard file: without the truth
  std::vector<RunDetectionRecord> detections;
  RunFrameRecord record;
  std::vector<ScorerSample> scorer_samples;  // never in a shard file
};

// Which evaluation a shard file belongs to: every field must agree for a
// merge to take it.
struct ShardHeader {
  int shard = 0, shards = 1;
  std::string dataset_hash;  // of every selected frame, as the run stores it
  std::string model_hash;
  std::string options_json;  // the run's stored options
};

void WriteShardFile(const std::string& path,
                    const ShardHeader& header,
                    const std::vector<EvaluatedFrame>& frames);

// The frames of a shard file whose header equals `expected`. Throws
// InputError naming the file for a missing file, one that is not a shard
// file, or a foreign shard (the field that differs and what to do).
std::vector<EvaluatedFrame> ReadShardFile(const std::string& path, const ShardHeader& expected);

// A shard file read as data anyone may have written: nesting, types and
// ranges of every field checked (one line naming the file, the field and the
// rule), whoever's evaluation it belongs to.
struct ShardFile {
  ShardHeader header;
  std::vector<EvaluatedFrame> frames;
};
ShardFile ParseShardFile(const std::string& path);

}  // namespace furn
