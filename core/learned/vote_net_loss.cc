#include "core/learned/vote_net_loss.h"

#include "core/error.h"
#include "core/learned/vote_net_loss_torch.h"

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

VoteNetLoss VoteNetLossOf(const torch::Tensor& output,
                          const TargetTensors& targets,
                          const VoteNetLossWeights& weights,
                          torch::Tensor* total) {
  namespace ch = bev_channels;
  auto slice = [](const torch::Tensor& t, BevSlice s) { return t.slice(1, s.first, s.end()); };
  const torch::Tensor cell_weight = targets.weight.unsqueeze(1);
  // Heat: focal loss, normalised by the number of centres.
  const torch::Tensor logits = slice(output, ch::kHeat);
  const torch::Tensor heat = slice(targets.values, ch::kHeat);
  const torch::Tensor p = torch::sigmoid(logits);
  const torch::Tensor positive = heat.ge(0.999).to(torch::kFloat32) * cell_weight;
  const torch::Tensor positives = positive.sum().clamp_min(1.0);
  const torch::Tensor pos_loss = (torch::log_sigmoid(logits) * (1 - p).pow(2) * positive).sum();
  const torch::Tensor negative = (1 - heat.ge(0.999).to(torch::kFloat32)) * cell_weight;
  const torch::Tensor neg_loss =
      (torch::log_sigmoid(-logits) * p.pow(2) * (1 - heat).pow(4) * negative).sum();
  const torch::Tensor heat_loss = -(pos_loss + neg_loss) / positives;
  // Regressions on voting cells.
  const torch::Tensor votes = targets.votes.unsqueeze(1);
  const torch::Tensor voting_cells = votes.sum().clamp_min(1.0);
  auto l1 = [&](BevSlice s) {
    return ((slice(output, s) - slice(targets.values, s)).abs() * votes).sum() /
           (voting_cells * static_cast<double>(s.count));
  };
  const torch::Tensor offset = l1(ch::kOffset);
  const torch::Tensor size = l1(ch::kLogSize);
  const torch::Tensor yaw = l1(ch::kYaw);
  // Membership: every cell, ignore regions aside.
  const torch::Tensor membership =
      torch::binary_cross_entropy_with_logits(slice(output, ch::kMembership),
                                              slice(targets.values, ch::kMembership),
                                              cell_weight,
                                              {},
                                              at::Reduction::Mean);
  const torch::Tensor h = heat_loss * weights.heat, o = offset * weights.offset,
                      s = size * weights.size, y = yaw * weights.yaw,
                      m = membership * weights.membership;
  torch::Tensor e = torch::zeros({}, output.options());
  if (targets.edges.defined()) {
    Require(output.size(1) >= ch::kEdges.end(), "a vote network without edge channels");
    const torch::Tensor cells = targets.edges.unsqueeze(1);
    e = ((slice(output, ch::kEdges) - slice(targets.values, ch::kEdges)).abs() * cells).sum() /
        (cells.sum().clamp_min(1.0) * static_cast<double>(ch::kEdges.count)) * weights.edges;
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
