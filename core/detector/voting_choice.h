// Which hypothesis source a detector uses (the learned vote map or the
// codebook's Hough votes): one rule for the detector and for the runs that
// record it.
//
//   const bool learned = UsesLearnedVoting(options.voting, !model.vote_net.empty());
#pragma once

#include "core/detector/detector.h"

namespace furn {

// Learned when asked for, or on kAuto when the model holds a vote network.
inline bool UsesLearnedVoting(VotingMode voting, bool model_has_vote_net) {
  return voting == VotingMode::kLearned || (voting == VotingMode::kAuto && model_has_vote_net);
}

}  // namespace furn
