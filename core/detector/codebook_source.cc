#include "core/detector/codebook_source.h"

#include "core/detector/detector_impl.h"

namespace furn {

Proposals CodebookSource::Propose(const DetectionInput& input,
                                  PreparedScan* prepared,
                                  bool keep_debug,
                                  StageTimer* timer,
                                  DetectionResult* result) const {
  detector_.SegmentScan(input, prepared);
  const PreparedScan& scan = *prepared;
  std::vector<StageTime>& stages = result->timings_ms.stages;
  stages.insert(stages.end(), scan.timings_ms.stages.begin(), scan.timings_ms.stages.end());
  timer->Restart();

  Proposals proposals;
  const VoteMaps votes = detector_.Vote(scan);
  timer->Lap(DetectionStage::kVote);
  proposals.hypotheses =
      detector_.FindMaxima(votes, keep_debug ? &result->debug.grids : nullptr, keep_debug);
  timer->Lap(DetectionStage::kMaxima);
  detector_.RankCandidates(scan, votes, &proposals.hypotheses);
  timer->Lap(DetectionStage::kRank);
  std::vector<FittedHypothesis> fits = detector_.FitAndVerify(scan, &proposals.hypotheses);
  timer->Lap(DetectionStage::kFitAndVerify);
  for (int h : detector_.Suppress(scan, fits, &proposals.hypotheses))
    proposals.candidates.push_back({*fits[h].detection, h, std::move(fits[h].fitted_points)});
  timer->Lap(DetectionStage::kSuppress);
  return proposals;
}

void CodebookSource::Record(const PreparedScan& scan,
                            Proposals* proposals,
                            DetectionDebug* debug) const {
  const ViewSegments& view = scan.view;
  debug->points = view.cloud.points;
  debug->segment_of_point.assign(view.cloud.size(), -1);
  for (size_t s = 0; s < view.segments.size(); ++s) {
    for (int i : view.segments[s]) debug->segment_of_point[i] = static_cast<int>(s);
  }
  for (Candidate& candidate : proposals->candidates)
    debug->fitted_points.push_back(std::move(candidate.fitted_points));
}

}  // namespace furn
