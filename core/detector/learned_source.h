// Learned voting (issues 30, 37), the default: the scan's bird's-eye-view
// image through the model's vote network; the heat maps' maxima, centred by
// the box coder (core/learned/bev_box_coder.h), are hypotheses and, unless
// suppressed (learned_decode.suppress_m > 0), candidates with the network's
// position, yaw and footprint. What the operating point keeps is refined:
// the CAD models ranked by the part subsets of the segments inside its box
// and fitted by RANSAC (DetectorOptions::learned_fit) give it their yaw and
// model where they agree, and the extent fit moves a box to the edges the
// scan saw (learned_extent_fit).
//
// Each step is a public stage a test calls alone:
//
//   LearnedSource source(detector);
//   const BevImage image = source.Rasterise(scan);
//   const BevOutput output = source.RunNetwork(image);
//   Proposals proposals = source.Decode(image, output);
#pragma once

#include "core/detector/hypothesis_source.h"

namespace furn {

class LearnedSource : public HypothesisSource {
 public:
  // The detector must hold a vote network (Detector::learned()).
  explicit LearnedSource(const Detector& detector);

  // The network's stages beside the segmentation its fits need (with one
  // torch thread: each on a core of its own), then Decode.
  Proposals Propose(const DetectionInput& input,
                    PreparedScan* scan,
                    bool keep_debug,
                    StageTimer* timer,
                    DetectionResult* result) const override;
  // FitCandidates (with learned_fit) then FitExtents.
  void Refine(const PreparedScan& scan, Proposals* proposals, StageTimer* timer) const override;
  // Every class's heat on a world grid, and the rasterised points above
  // the floor.
  void Record(const PreparedScan& scan, Proposals* proposals, DetectionDebug* debug) const override;

  // The placed scan's camera points within the network's own range (it was
  // trained on it, not the codebook's max_range_m) as its BEV image.
  BevImage Rasterise(const PreparedScan& scan) const;
  // The network's output (averaged with the mirrored image's when
  // learned_mirror_average), on the calling thread's torch threads.
  BevOutput RunNetwork(const BevImage& image) const;
  // The output's maxima (DecodeBevOutput) as hypotheses, the unsuppressed
  // ones as candidates, strongest first.
  Proposals Decode(const BevImage& image, const BevOutput& output) const;
  // The detection one decoded maximum stands for, before any refinement:
  // the network's class, centre, yaw and footprint, its heat as score. The
  // one mapping from the network's output to detections: Decode uses it,
  // and so does the operating-point choice on validation frames.
  static Detection DetectionOf(const BevPeak& peak);
  // Each candidate's CAD models ranked by the segments inside its box and
  // fitted; an agreeing best fit gives it its yaw and model.
  void FitCandidates(const PreparedScan& scan, Proposals* proposals) const;
  // The extent fit of the candidates of learned_extent_fit's classes.
  void FitExtents(const PreparedScan& scan, Proposals* proposals) const;

 private:
  const Detector& detector_;
};

}  // namespace furn
