// What a model file holds, in words: `model info`, its operating point, the
// input its vote network was trained on, and the note detection prints when
// it meets the other kind of input.
#pragma once

#include <string>

#include "core/model/trained_model.h"

namespace furn {

// `model info`'s words for it: "single frames", "fused frames in 50 % of its
// training, their room-mates off by 2 cm / 1 deg", or "not recorded (…)".
std::string DescribeVoteNetInput(const VoteNetInput& input);
// A one-line note (empty when there is none) for detecting with the model's
// vote network on input of the other kind than it was trained on: fused scans
// (`fused_input`) to a network trained on single frames, or single frames to
// one trained fused. Nothing for a codebook model or an unrecorded input.
std::string VoteNetInputNote(const TrainedModel& model,
                             const std::string& model_path,
                             bool fused_input);

// `model info`: what a model file holds, as text.
std::string DescribeTrainedModel(const TrainedModel& model);

// What a detection's score is with this model (the learned path: the vote
// network's heat, not calibrated; the codebook with a scorer: a Platt-scaled
// probability), as `model info` and the docs say it.
std::string ScoreMeaning(const TrainedModel& model);

// The model file's content hash (XXH3-128, 32 hex digits), as evaluation
// runs store it and the detection JSON names it.
std::string ModelFileHash(const std::string& path);
// The operating point's lines of `model info`: each class's threshold and
// what it measured where it was chosen.
std::string DescribeOperatingPoint(const OperatingPoint& point);

}  // namespace furn
