// Where a detection's hypotheses come from: one implementation per file,
// chosen by the detector from the model and its options (VotingMode),
//
//   CodebookSource (codebook_source.h): the paper's Hough votes of the
//     segments' words, their maxima, the part-subset ranking, and each
//     candidate fitted, verified, scored and suppressed;
//   LearnedSource (learned_source.h): the bird's-eye-view image, the vote
//     network, its decoded maxima; what the operating point keeps refined by
//     the CAD fit and the extent fit;
//
// and one tail that both go through (Detector::Detect): the operating point
// (KeepAtOperatingPoint), the source's refinement of what it kept, each
// detection's share in view, the timings and the debug record.
#pragma once

#include <vector>

#include "core/detector/detector.h"
#include "core/learned/bev_grid.h"

namespace furn {

class StageTimer;

// A hypothesis that became a detection candidate.
struct Candidate {
  Detection detection;
  int hypothesis = -1;  // into Proposals::hypotheses
  // The posed CAD model (world frame) that explains it; empty when the
  // source fits none.
  std::vector<Eigen::Vector3f> fitted_points;
};

struct Proposals {
  std::vector<DetectionDebug::Hypothesis> hypotheses;  // every one, in the source's order
  std::vector<Candidate> candidates;                   // best first
  // Learned voting: the network's image and output, which its refinement
  // and its debug record read.
  BevImage image;
  BevOutput output;
};

class HypothesisSource {
 public:
  virtual ~HypothesisSource() = default;
  // The placed scan's hypotheses and candidates, after the source's own
  // suppression and before the operating point. Segments the scan
  // (Detector::SegmentScan) where the source or its refinement needs it,
  // and records its stage times in `result` (and the vote grids when
  // keep_debug); the tail counts the segmented points and segments.
  virtual Proposals Propose(const DetectionInput& input,
                            PreparedScan* scan,
                            bool keep_debug,
                            StageTimer* timer,
                            DetectionResult* result) const = 0;
  // The candidates the operating point kept, refined against the scan.
  virtual void Refine(const PreparedScan& scan, Proposals* proposals, StageTimer* timer) const = 0;
  // The scan's points (and segments) and the kept fits, for reports.
  virtual void Record(const PreparedScan& scan,
                      Proposals* proposals,
                      DetectionDebug* debug) const = 0;
};

// The tail's operating point: the candidates whose score reaches their
// class's threshold stay (in order); the others' hypotheses get outcome
// kBelowOperatingPoint with their score and the threshold.
void KeepAtOperatingPoint(const OperatingPoint& point, Proposals* proposals);

}  // namespace furn
