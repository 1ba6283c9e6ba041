// The vote network's training loss (issue 37), apart from the network:
//   heat        CenterNet's penalty-reduced focal loss (alpha 2, beta 4) on the
//               heat logits, per positive (centre cell), zero in ignore regions;
//   offset      L1 of the dense votes (units of bev_channels::kOffsetUnitM) on
//               every cell that votes (BevTargets::votes);
//   size, yaw   L1 of the log footprint and (cos, sin) on the same cells;
//   membership  binary cross-entropy of "the cell votes", every cell, zero in
//               ignore regions;
//   edges       with edge votes, L1 of the log edge distances on every cell
//               inside a target (BevTargets::edges).
// Each term is a mean (per positive, per voting cell and channel, per cell)
// times its weight.
//
//   VoteNetLossWeights weights;           // all 1
//   const VoteNetLoss loss = EvaluateVoteNetLoss(net, images, targets, weights);
#pragma once

namespace furn {

struct VoteNetLossWeights {
  double heat = 1, offset = 1, size = 1, yaw = 1, membership = 1, edges = 1;

  // Throws InputError naming the term and the rule.
  void Check() const;
};

// Loss terms of one batch (already weighted).
struct VoteNetLoss {
  double heat = 0, offset = 0, size = 0, yaw = 0, membership = 0, edges = 0;
  double Total() const { return heat + offset + size + yaw + membership + edges; }
  VoteNetLoss& operator+=(const VoteNetLoss& other) {
    heat += other.heat;
    offset += other.offset;
    size += other.size;
    yaw += other.yaw;
    membership += other.membership;
    edges += other.edges;
    return *this;
  }
  VoteNetLoss Scaled(double factor) const {
    return {heat * factor,
            offset * factor,
            size * factor,
            yaw * factor,
            membership * factor,
            edges * factor};
  }
};

}  // namespace furn
