#include "core/learned/vote_net_loss.h"

#include <algorithm>

#include "core/learned/vote_net_loss_torch.h"
#include "core/util/error.h"

namespace furn {

void VoteNetLossWeights::Check() const {
  for (const auto& [name, value] : {std::pair<const char*, double>{"heat", heat},
                                    {"offset", offset},
                                    {"size", size},
                                    {"yaw", yaw},
                                    {"membership", membership},
                                    {"edges", edges}}) {
    Require(value >= 0 && value <= 100,
            std::string("vote loss weight ") + name + " " + std::to_string(value) +
                " must be in 0..100");
  }
}

namespace {

torch::Tensor Slice(const torch::Tensor& t, BevSlice s) { return t.slice(1, s.first, s.end()); }

// The heat targets' positive cells (a centre), ignore regions aside.
torch::Tensor PositiveCells(const TargetTensors& targets) {
  return Slice(targets.values, bev_channels::kHeat).ge(0.999).to(torch::kFloat32) *
         targets.weight.unsqueeze(1);
}

}  // namespace

LossNormalisers LossNormalisersOf(const TargetTensors& targets) {
  LossNormalisers n;
  n.positives = PositiveCells(targets).sum().item<double>();
  n.voting_cells = targets.votes.sum().item<double>();
  n.cells = static_cast<double>(targets.weight.numel());
  if (targets.edges.defined()) n.edge_cells = targets.edges.sum().item<double>();
  return n;
}

VoteNetLoss VoteNetLossOf(const torch::Tensor& output,
                          const TargetTensors& targets,
                          const VoteNetLossWeights& weights,
                          torch::Tensor* total,
                          const LossNormalisers* normalisers) {
  namespace ch = bev_channels;
  const LossNormalisers n = normalisers != nullptr ? *normalisers : LossNormalisersOf(targets);
  const torch::Tensor cell_weight = targets.weight.unsqueeze(1);
  // Heat: focal loss, normalised by the number of centres.
  const torch::Tensor logits = Slice(output, ch::kHeat);
  const torch::Tensor heat = Slice(targets.values, ch::kHeat);
  const torch::Tensor p = torch::sigmoid(logits);
  const torch::Tensor positive = PositiveCells(targets);
  const double positives = std::max(1.0, n.positives);
  const torch::Tensor pos_loss = (torch::log_sigmoid(logits) * (1 - p).pow(2) * positive).sum();
  const torch::Tensor negative = (1 - heat.ge(0.999).to(torch::kFloat32)) * cell_weight;
  const torch::Tensor neg_loss =
      (torch::log_sigmoid(-logits) * p.pow(2) * (1 - heat).pow(4) * negative).sum();
  const torch::Tensor heat_loss = -(pos_loss + neg_loss) / positives;
  // Regressions on voting cells.
  const torch::Tensor votes = targets.votes.unsqueeze(1);
  const double voting_cells = std::max(1.0, n.voting_cells);
  auto l1 = [&](BevSlice s) {
    return ((Slice(output, s) - Slice(targets.values, s)).abs() * votes).sum() /
           (voting_cells * static_cast<double>(s.count));
  };
  const torch::Tensor offset = l1(ch::kOffset);
  const torch::Tensor size = l1(ch::kLogSize);
  const torch::Tensor yaw = l1(ch::kYaw);
  // Membership: every cell, ignore regions aside (the mean over the cells).
  const torch::Tensor membership =
      torch::binary_cross_entropy_with_logits(Slice(output, ch::kMembership),
                                              Slice(targets.values, ch::kMembership),
                                              cell_weight,
                                              {},
                                              at::Reduction::Sum) /
      std::max(1.0, n.cells);
  const torch::Tensor h = heat_loss * weights.heat, o = offset * weights.offset,
                      s = size * weights.size, y = yaw * weights.yaw,
                      m = membership * weights.membership;
  torch::Tensor e = torch::zeros({}, output.options());
  if (targets.edges.defined()) {
    Require(output.size(1) >= ch::kEdges.end(), "a vote network without edge channels");
    const torch::Tensor cells = targets.edges.unsqueeze(1);
    e = ((Slice(output, ch::kEdges) - Slice(targets.values, ch::kEdges)).abs() * cells).sum() /
        (std::max(1.0, n.edge_cells) * static_cast<double>(ch::kEdges.count)) * weights.edges;
  }
  if (total != nullptr) *total = h + o + s + y + m + e;
  return {h.item<double>(),
          o.item<double>(),
          s.item<double>(),
          y.item<double>(),
          m.item<double>(),
          e.item<double>()};
}

}  // namespace furn
