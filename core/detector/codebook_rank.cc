// Stage 4-5 of detection: the segments behind each maximum, their VFH
// descriptors, and the candidate CAD models ranked by the nearest part
// subsets (SPEC §8.3).
#include <algorithm>
#include <iterator>

#include "core/detector/detector_impl.h"
#include "core/util/parallel.h"

namespace furn {
namespace {

constexpr double kSameSupport = 0.8;  // shared share of segments making two maxima one

}  // namespace

std::map<int, double> Detector::Impl::Support(const std::vector<HoughVote>& class_votes,
                                              DetectionDebug::Hypothesis* hypothesis) const {
  // Segments that voted for this class near the maximum, with their weight there.
  const float radius2 = static_cast<float>(options.support_radius_m * options.support_radius_m);
  std::map<int, double> support;
  for (const HoughVote& vote : class_votes) {
    const float dx = vote.x - static_cast<float>(hypothesis->x);
    const float dy = vote.y - static_cast<float>(hypothesis->y);
    if (dx * dx + dy * dy <= radius2) support[vote.segment] += vote.weight;
  }
  for (const auto& [segment, weight] : support) hypothesis->segments.push_back(segment);
  return support;
}

void Detector::Impl::Rank(const std::map<int, double>& support,
                          const std::vector<std::vector<int>>& segment_neighbours,
                          DetectionDebug::Hypothesis* hypothesis) const {
  if (support.empty()) {
    hypothesis->outcome = HypothesisOutcome::kNoSupport;
    return;
  }
  // CAD models of this class ranked by the part subsets nearest to each
  // supporting segment: a neighbour at rank r adds weight / (r + 1).
  std::map<int, double> model_score;
  for (const auto& [segment, weight] : support) {
    const std::vector<int>& neighbours = segment_neighbours[segment];
    for (size_t r = 0; r < neighbours.size(); ++r) {
      const int m = model.part_models[neighbours[r]];
      if (model.model_classes[m] == hypothesis->furniture_class) model_score[m] += weight / (r + 1);
    }
  }
  std::vector<std::pair<double, int>> ranked;
  for (const auto& [m, score] : model_score) ranked.emplace_back(-score, m);
  std::sort(ranked.begin(), ranked.end());
  for (const auto& [negative_score, m] : ranked) {
    if (static_cast<int>(hypothesis->candidate_models.size()) < options.top_models)
      hypothesis->candidate_models.push_back(m);
  }
  // Too few ranked: the class's other models, in catalog order.
  for (size_t m = 0; m < model.model_classes.size(); ++m) {
    if (static_cast<int>(hypothesis->candidate_models.size()) >= options.top_models) break;
    if (model.model_classes[m] == hypothesis->furniture_class && model_score.count(m) == 0)
      hypothesis->candidate_models.push_back(static_cast<int>(m));
  }
}

std::vector<std::vector<int>> Detector::Impl::SegmentNeighbours(
    const PreparedScan& scan, const std::vector<std::map<int, double>>& supports) const {
  const ViewSegments& view = scan.view;
  std::vector<char> needed(view.segments.size(), 0);
  for (const auto& support : supports) {
    for (const auto& [segment, weight] : support) needed[segment] = 1;
  }
  std::vector<int> queried;  // segments whose neighbours are needed
  for (size_t s = 0; s < view.segments.size(); ++s) {
    if (needed[s] && view.segments[s].size() >= 3) queried.push_back(static_cast<int>(s));
  }
  std::vector<VfhDescriptor> descriptors(queried.size());
  ParallelFor(0, static_cast<int>(queried.size()), [&](int q) {
    descriptors[q] = ComputeVfh(view.cloud,
                                view.segments[queried[q]],
                                scan.sensor,
                                model.options.part_subsets.vfh_size_component);
  });
  std::vector<std::vector<int>> nearest = parts->NearestMany(descriptors, options.neighbours);
  std::vector<std::vector<int>> segment_neighbours(view.segments.size());
  for (size_t q = 0; q < queried.size(); ++q)
    segment_neighbours[queried[q]] = std::move(nearest[q]);
  return segment_neighbours;
}

void Detector::RankCandidates(const PreparedScan& scan,
                              const VoteMaps& votes,
                              std::vector<DetectionDebug::Hypothesis>* hypotheses_out) const {
  const Impl& impl = *impl_;
  std::vector<DetectionDebug::Hypothesis>& hypotheses = *hypotheses_out;
  // The segments behind each maximum; then each such segment's nearest
  // part subsets, once for all hypotheses.
  std::vector<std::vector<HoughVote>> votes_of_class(kClasses);
  for (const HoughVote& vote : votes.votes) votes_of_class[vote.class_index].push_back(vote);
  std::vector<std::map<int, double>> supports(hypotheses.size());
  ParallelFor(0, static_cast<int>(hypotheses.size()), [&](int h) {
    supports[h] = impl.Support(votes_of_class[static_cast<int>(hypotheses[h].furniture_class)],
                               &hypotheses[h]);
  });
  const std::vector<std::vector<int>> segment_neighbours = impl.SegmentNeighbours(scan, supports);
  for (size_t h = 0; h < hypotheses.size(); ++h)
    impl.Rank(supports[h], segment_neighbours, &hypotheses[h]);
  // Maxima of one class backed by (almost) the same segments would give the
  // same fit: only the strongest is fitted (hypotheses are strongest first
  // within a class).
  for (size_t h = 0; h < hypotheses.size(); ++h) {
    for (size_t k = 0; k < h; ++k) {
      if (hypotheses[k].furniture_class != hypotheses[h].furniture_class ||
          hypotheses[k].candidate_models.empty()) {
        continue;
      }
      const std::vector<int>& a = hypotheses[k].segments;
      const std::vector<int>& b = hypotheses[h].segments;
      std::vector<int> common;
      std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(common));
      if (common.size() >= kSameSupport * std::max(a.size(), b.size())) {
        hypotheses[h].candidate_models.clear();
        hypotheses[h].outcome = HypothesisOutcome::kSameSupport;
        break;
      }
    }
  }
}

}  // namespace furn
