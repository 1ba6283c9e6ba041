// Private to the learned library's .cc files (it includes torch): the loss of
// vote_net_loss.h on tensors.
#pragma once

#include "core/learned/vote_net_loss.h"
#include "core/learned/vote_net_module.h"

namespace furn {

// The weighted terms of `output` (N x kCount x rows x cols, logits) against
// `targets`; `total`, when given, receives their sum for backward().
VoteNetLoss VoteNetLossOf(const torch::Tensor& output,
                          const TargetTensors& targets,
                          const VoteNetLossWeights& weights,
                          torch::Tensor* total);

}  // namespace furn
