// Stages 2 and 3 of detection: probabilistic Hough voting on per-class grids
// (SPEC §8.2, paper eq. 7) and their local maxima (eq. 8).
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/detector/detector_impl.h"
#include "core/util/parallel.h"

namespace furn {

std::vector<DetectionDebug::Hypothesis> Detector::Impl::Maxima(
    const cv::Mat& grid,
    int class_index,
    const Eigen::Vector2f& origin,
    DetectionDebug::VoteGrid* debug) const {
  double low = 0, high = 0;
  cv::minMaxLoc(grid, &low, &high);
  const double threshold =
      std::max(low + options.relative_threshold * (high - low), options.absolute_threshold);
  debug->threshold = threshold;
  std::vector<DetectionDebug::Hypothesis> maxima;
  if (high <= 0) return maxima;
  // Local maxima in a window half the class's (median) width across: equal
  // to the grid's maximum filter there (the paper's window).
  const int half =
      std::max(1, static_cast<int>(std::lround(0.25 * class_width[class_index] / options.cell_m)));
  cv::Mat dilated;
  cv::dilate(
      grid, dilated, cv::getStructuringElement(cv::MORPH_RECT, {2 * half + 1, 2 * half + 1}));
  std::vector<std::pair<float, int>> candidates;  // value, cell
  for (int r = 0; r < grid.rows; ++r) {
    const float* g = grid.ptr<float>(r);
    const float* d = dilated.ptr<float>(r);
    for (int c = 0; c < grid.cols; ++c) {
      if (g[c] > 0 && g[c] >= threshold && g[c] >= d[c])
        candidates.emplace_back(g[c], r * grid.cols + c);
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  for (const auto& [value, cell] : candidates) {
    const int r = cell / grid.cols, c = cell % grid.cols;
    // Plateaus give several equal cells: keep the first of each window.
    bool near_kept = false;
    for (const DetectionDebug::Hypothesis& kept : maxima) {
      const double dc = (kept.x - origin.x()) / options.cell_m - 0.5 - c;
      const double dr = (kept.y - origin.y()) / options.cell_m - 0.5 - r;
      near_kept |= std::abs(dc) <= half && std::abs(dr) <= half;
    }
    if (near_kept) continue;
    DetectionDebug::Hypothesis hypothesis;
    hypothesis.furniture_class = kAllClasses[class_index];
    hypothesis.x = origin.x() + (c + 0.5) * options.cell_m;
    hypothesis.y = origin.y() + (r + 0.5) * options.cell_m;
    hypothesis.vote_weight = value;
    hypothesis.relative_weight = high > low ? (value - low) / (high - low) : 0.0;
    maxima.push_back(hypothesis);
    if (static_cast<int>(maxima.size()) >= options.max_hypotheses_per_class) break;
  }
  return maxima;
}

VoteMaps Detector::Vote(const PreparedScan& scan) const {
  const Impl& impl = *impl_;
  const DetectorOptions& options = impl.options;
  const TrainedModel& model = impl.model;
  const ViewSegments& view = scan.view;
  VoteMaps maps;
  maps.cell_m = options.cell_m;
  maps.grids.resize(kClasses);
  if (view.segments.empty()) return maps;
  // Per-class grids covering the scene plus a margin.
  Eigen::Vector2f low(1e9f, 1e9f), high(-1e9f, -1e9f);
  for (const Eigen::Vector3f& p : view.cloud.points) {
    low = low.cwiseMin(p.head<2>());
    high = high.cwiseMax(p.head<2>());
  }
  const float margin = 1.0f;
  maps.origin = low - Eigen::Vector2f::Constant(margin);
  maps.cols = std::min(
      2000, static_cast<int>(std::ceil((high.x() - low.x() + 2 * margin) / options.cell_m)));
  maps.rows = std::min(
      2000, static_cast<int>(std::ceil((high.y() - low.y() + 2 * margin) / options.cell_m)));
  // Each segment's votes on its own (both cores), then added up in segment
  // order: the same sums, in the same order, as one loop.
  std::vector<std::vector<HoughVote>> votes_of_segment(view.segments.size());
  ParallelFor(0, static_cast<int>(view.segments.size()), [&](int s) {
    if (scan.structure_segment[s]) return;
    const Eigen::Vector3f& centroid = view.centroids[s];
    // Relations were stored in the view-aligned frame: back to world.
    const Eigen::Matrix2f world_from_aligned =
        ViewAlignedFromWorld(scan.sensor, centroid).transpose();
    for (const WordActivation& activation :
         model.vocabulary.Activate(model.normalizer.Apply(view.features[s]))) {
      for (int e : impl.entries_of_word[activation.word]) {
        const ShapeEntry& entry = model.shape[e];
        if (options.vote_height_tolerance_m > 0 &&
            std::abs(entry.height - centroid.z()) > options.vote_height_tolerance_m) {
          continue;
        }
        const int class_index = static_cast<int>(entry.furniture_class);
        const Eigen::Vector2f at = centroid.head<2>() + world_from_aligned * entry.relation;
        const auto weight = static_cast<float>(
            activation.probability / impl.entries_per_class[activation.word][class_index]);
        votes_of_segment[s].push_back({s, class_index, at.x(), at.y(), weight});
      }
    }
  });
  std::vector<cv::Mat> grids(kClasses);
  for (cv::Mat& grid : grids) grid = cv::Mat::zeros(maps.rows, maps.cols, CV_32F);
  size_t total = 0;
  for (const auto& votes : votes_of_segment) total += votes.size();
  maps.votes.reserve(total);
  for (const auto& votes : votes_of_segment) {
    for (const HoughVote& vote : votes) {
      const int c = static_cast<int>(std::floor((vote.x - maps.origin.x()) / options.cell_m));
      const int r = static_cast<int>(std::floor((vote.y - maps.origin.y()) / options.cell_m));
      if (c < 0 || r < 0 || c >= maps.cols || r >= maps.rows) continue;
      grids[vote.class_index].at<float>(r, c) += vote.weight;
      maps.votes.push_back(vote);
    }
  }
  if (options.vote_sigma_m > 0) {
    const double sigma = options.vote_sigma_m / options.cell_m;
    for (cv::Mat& grid : grids) cv::GaussianBlur(grid, grid, cv::Size(0, 0), sigma, sigma);
  }
  for (int k = 0; k < kClasses; ++k)
    maps.grids[k].assign(grids[k].begin<float>(), grids[k].end<float>());
  return maps;
}

std::vector<DetectionDebug::Hypothesis> Detector::FindMaxima(
    const VoteMaps& votes, std::vector<DetectionDebug::VoteGrid>* grids, bool keep_values) const {
  const Impl& impl = *impl_;
  std::vector<DetectionDebug::Hypothesis> hypotheses;
  for (int k = 0; k < kClasses; ++k) {
    if (impl.class_width[k] <= 0 || votes.grids.size() <= static_cast<size_t>(k) ||
        votes.grids[k].empty()) {
      continue;
    }
    DetectionDebug::VoteGrid debug_grid;
    debug_grid.furniture_class = kAllClasses[k];
    debug_grid.origin = votes.origin;
    debug_grid.cell_m = votes.cell_m;
    debug_grid.cols = votes.cols;
    debug_grid.rows = votes.rows;
    // A view of the grid, not a copy (Maxima only reads it).
    const cv::Mat grid(votes.rows, votes.cols, CV_32F, const_cast<float*>(votes.grids[k].data()));
    for (auto& h : impl.Maxima(grid, k, votes.origin, &debug_grid)) hypotheses.push_back(h);
    if (grids != nullptr) {
      if (keep_values) debug_grid.values = votes.grids[k];
      grids->push_back(std::move(debug_grid));
    }
  }
  return hypotheses;
}

}  // namespace furn
