// Codebook voting, the paper's path (SPEC §8 steps 2 to 7): the segments'
// Hough votes, their maxima, the part-subset ranking of CAD models, and
// every candidate fitted, verified, scored and suppressed. Each step is a
// public stage of the Detector (Vote, FindMaxima, RankCandidates,
// FitAndVerify, Suppress) that a test calls alone; this source runs them in
// order.
#pragma once

#include "core/detector/hypothesis_source.h"

namespace furn {

class CodebookSource : public HypothesisSource {
 public:
  explicit CodebookSource(const Detector& detector) : detector_(detector) {}

  Proposals Propose(const DetectionInput& input,
                    PreparedScan* scan,
                    bool keep_debug,
                    StageTimer* timer,
                    DetectionResult* result) const override;
  // Its candidates are fitted already: nothing more to refine.
  void Refine(const PreparedScan&, Proposals*, StageTimer*) const override {}
  void Record(const PreparedScan& scan, Proposals* proposals, DetectionDebug* debug) const override;

 private:
  const Detector& detector_;
};

}  // namespace furn
