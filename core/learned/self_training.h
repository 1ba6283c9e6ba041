// Self-training's labels (issue 69): what a trained vote network finds with
// confidence on a user's own unlabelled scans becomes their targets, so that
// fine-tuning on those scans (with generated rooms beside them) raises the
// heat the real sensor's furniture gets. A maximum is a pseudo-target when
// its heat reaches its class's threshold on the image and on the image's
// mirror (the mirror's maximum of the same class within mirror_match_m: the
// network sees it both ways, a check the labels' precision needs); every
// other maximum with some heat is ignored (the loss neither rewards nor
// punishes the heat around it, as it ignores objects seen too little), so a
// real object the network is unsure of is not taught to be background.
//
//   PseudoLabelOptions options;
//   options.min_heat = ThresholdsOf(model.operating_point);
//   PseudoLabelCounts counts;
//   const BevSample sample = PseudoLabelledSample(net, image, options, &counts);
#pragma once

#include <array>

#include "core/learned/bev_box_coder.h"
#include "core/learned/vote_net.h"
#include "core/learned/vote_net_training.h"

namespace furn {

struct PseudoLabelOptions {
  // Per class, the least heat of a pseudo-target on the image and on its
  // mirror (a model's operating point's thresholds; a class without one
  // takes fallback_min_heat).
  std::array<double, kBevClasses> min_heat{-1, -1, -1, -1, -1};
  double fallback_min_heat = 0.5;
  // The thresholds scaled by this (1: the operating point itself).
  double heat_share = 1;
  // The mirror's maximum of the same class this near (m) confirms one.
  double mirror_match_m = 0.3;
  // Maxima with at least this heat that are not pseudo-targets are ignored.
  double ignore_min_heat = 0.1;
  BevDecodeOptions decode;  // how maxima are found (detection's decoding)

  // Throws InputError naming the option and the rule.
  void Check() const;
  // The threshold of a class after heat_share.
  double Threshold(FurnitureClass furniture_class) const;
};

struct PseudoLabelCounts {
  std::array<int, kBevClasses> targets{};  // per class
  int ignored = 0;
  int images = 0;
  int Targets() const;
};

// The image with the network's confident, mirror-consistent maxima as
// targets (footprint and yaw as decoded; centre the mean of the two views')
// and its other maxima ignored. Adds to *counts when given.
BevSample PseudoLabelledSample(const VoteNet& net,
                               const BevImage& image,
                               const PseudoLabelOptions& options,
                               PseudoLabelCounts* counts);

}  // namespace furn
