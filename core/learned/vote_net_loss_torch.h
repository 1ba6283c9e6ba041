// Private to the learned library's .cc files (it includes torch): the loss of
// vote_net_loss.h on tensors.
#pragma once

#include "core/learned/vote_net_loss.h"
#include "core/learned/vote_net_module.h"

namespace furn {

// What each term is divided by: the heat's positive cells, the voting cells
// of the regressions, the membership's cells (batch x rows x cols) and the
// edge votes' cells. A data-parallel step sums them over the ranks (each
// holding part of one batch), so that the ranks' gradients add up to the
// whole batch's.
struct LossNormalisers {
  double positives = 0, voting_cells = 0, cells = 0, edge_cells = 0;
};
LossNormalisers LossNormalisersOf(const TargetTensors& targets);

// The weighted terms of `output` (N x kCount x rows x cols, logits) against
// `targets`; `total`, when given, receives their sum for backward().
// `normalisers`: the whole batch's (LossNormalisersOf summed over the ranks
// of a data-parallel step); null: the batch's own.
VoteNetLoss VoteNetLossOf(const torch::Tensor& output,
                          const TargetTensors& targets,
                          const VoteNetLossWeights& weights,
                          torch::Tensor* total,
                          const LossNormalisers* normalisers = nullptr);

}  // namespace furn
