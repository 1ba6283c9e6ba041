// The vote network's training checkpoint (issue 72): everything the loop
// needs to go on after a completed epoch as if it had never stopped — the
// network (weights and batch-norm statistics), Adam's moments and step
// counts, the batch generator's state, the weight average, and the epochs'
// records. Written after every epoch to a temporary file and renamed over
// the last one, so a kill at any moment leaves the previous checkpoint
// whole. A checkpoint names the training it belongs to by a fingerprint of
// the training samples, the options that steer the loop and the initial
// weights; another training's checkpoint is ignored (and replaced).
//
//   const std::string id = TrainingFingerprint(training, validation, options, net);
//   if (std::optional<VoteNetCheckpoint> saved = ReadCheckpoint(path, id)) ... resume
//   WriteCheckpoint(path, checkpoint);
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/learned/vote_net.h"
#include "core/learned/vote_net_training.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn {

struct VoteNetCheckpoint {
  std::string fingerprint;  // TrainingFingerprint's
  int epochs_done = 0;
  uint64_t steps_done = 0;
  std::string generator;  // std::mt19937_64's state, as its operator<< writes it
  std::string net;        // VoteNet::Serialize
  std::string adam;       // VoteNetOptimizer::SaveState
  std::string average;    // the weight average's VoteNet::Serialize; empty: none
  int64_t average_updates = 0;
  std::vector<VoteNetEpoch> epochs;  // the records so far
};

// XXH3-128 (32 hex digits) over the samples (images, objects, visibility),
// the loop's options (epochs, batch, rate, loss weights, average, threads
// are not in it: they do not change the result's meaning) and the initial
// network's bytes (its architecture and seed).
std::string TrainingFingerprint(const std::vector<BevSample>& training,
                                const std::vector<BevSample>& validation,
                                const VoteNetTrainingOptions& options,
                                const VoteNet& initial);

// Writes `path` atomically (a temporary file renamed over it).
void WriteCheckpoint(const std::string& path, const VoteNetCheckpoint& checkpoint);

// The checkpoint at `path` when it is one of this training's (fingerprint
// equal); nothing when there is none, it is another training's, or it
// cannot be read (a note on stderr says which, unless `quiet`). Bounded:
// every length is checked against the file's bytes.
std::optional<VoteNetCheckpoint> ReadCheckpoint(const std::string& path,
                                                const std::string& fingerprint,
                                                bool quiet);

// The checkpoint files of a training with these options (its members'
// too), removed once the model that needed them is written.
void RemoveCheckpoints(const VoteNetTrainingOptions& options);

// The checkpoint path of ensemble member k of a training at `path`.
std::string MemberCheckpointPath(const std::string& path, int member);

}  // namespace furn
