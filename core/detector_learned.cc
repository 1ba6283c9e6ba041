// Learned voting (issues 30, 37): the scan's bird's-eye-view image through
// the model's vote network; the heat maps' maxima, centred by the box coder
// (core/learned/bev_box_coder.h), are hypotheses and, unless suppressed
// (learned_decode.suppress_m > 0), detections with the network's position, yaw and
// footprint.
#include <algorithm>
#include <cmath>
#include <map>

#include "core/detector.h"
#include "core/detector_impl.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/render_compare.h"

namespace furn {
namespace {

// A class's heat resampled onto a world-aligned grid (the reports' vote
// panels are world-aligned); cells outside the network's grid are 0.
DetectionDebug::VoteGrid WorldGridOf(const BevImage& image,
                                     const BevOutput& output,
                                     int class_index,
                                     double threshold) {
  const BevGridSpec& spec = image.spec;
  Eigen::Vector2d low(1e30, 1e30), high(-1e30, -1e30);
  for (const Eigen::Vector2d& corner : {Eigen::Vector2d(0, 0),
                                        Eigen::Vector2d(spec.rows, 0),
                                        Eigen::Vector2d(0, spec.cols),
                                        Eigen::Vector2d(spec.rows, spec.cols)}) {
    const Eigen::Vector2d world = image.frame.WorldOf(corner, spec);
    low = low.cwiseMin(world);
    high = high.cwiseMax(world);
  }
  DetectionDebug::VoteGrid grid;
  grid.furniture_class = kAllClasses[class_index];
  grid.origin = low.cast<float>();
  grid.cell_m = spec.cell_m;
  grid.cols = static_cast<int>(std::ceil((high.x() - low.x()) / spec.cell_m));
  grid.rows = static_cast<int>(std::ceil((high.y() - low.y()) / spec.cell_m));
  grid.threshold = threshold;
  grid.learned = true;
  grid.values.assign(static_cast<size_t>(grid.rows) * grid.cols, 0.0f);
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const Eigen::Vector2d world = low + Eigen::Vector2d(c + 0.5, r + 0.5) * spec.cell_m;
      const Eigen::Vector2d cell = image.frame.CellOf(world, spec);
      const int row = static_cast<int>(std::floor(cell.x()));
      const int col = static_cast<int>(std::floor(cell.y()));
      if (row < 0 || row >= spec.rows || col < 0 || col >= spec.cols) continue;
      grid.values[static_cast<size_t>(r) * grid.cols + c] =
          output.At(bev_channels::kHeat[class_index], row, col);
    }
  }
  return grid;
}

// Segments mostly inside a learned hypothesis's box (widened by
// kSupportMarginM), structure left out, weighted by their points inside:
// what the CAD models are ranked by.
constexpr double kSupportMarginM = 0.1;
constexpr double kMostlyInside = 0.5;

std::map<int, double> SegmentsInBox(const PreparedScan& scan,
                                    const DetectionDebug::Hypothesis& hypothesis) {
  const double c = std::cos(hypothesis.yaw), s = std::sin(hypothesis.yaw);
  const double half_w = hypothesis.width / 2 + kSupportMarginM,
               half_d = hypothesis.depth / 2 + kSupportMarginM;
  std::map<int, double> support;
  const ViewSegments& view = scan.view;
  for (size_t segment = 0; segment < view.segments.size(); ++segment) {
    if (scan.structure_segment[segment]) continue;
    const std::vector<int>& members = view.segments[segment];
    size_t inside = 0;
    for (int i : members) {
      const Eigen::Vector3f& p = view.cloud.points[i];
      const double dx = p.x() - hypothesis.x, dy = p.y() - hypothesis.y;
      inside += std::abs(c * dx + s * dy) <= half_w && std::abs(-s * dx + c * dy) <= half_d;
    }
    if (inside > 0 && inside >= kMostlyInside * members.size())
      support.emplace(static_cast<int>(segment), static_cast<double>(inside));
  }
  return support;
}

// The extent fit's visibility test: the scan's own depth image where it is
// organised (VisibilityInScan), else the BEV image's lenient test.
VisibilityTest ScanVisibility(const PreparedScan& scan, const BevImage& image) {
  if (!scan.intrinsics || scan.width == 0)
    return [&image](const Eigen::Vector3d& world) { return BevVisibility(image, world); };
  const Eigen::Isometry3d camera_from_world = scan.world_from_camera.inverse();
  return [&scan, camera_from_world](const Eigen::Vector3d& world) {
    return VisibilityInScan(
        scan.camera_points, scan.width, scan.height, *scan.intrinsics, camera_from_world * world);
  };
}

}  // namespace

void Detector::ExtentFitLearned(const PreparedScan& scan,
                                const BevImage& image,
                                std::vector<DetectionDebug::Hypothesis>* hypotheses,
                                std::vector<Detection>* detections) const {
  const ExtentFitClasses classes = impl_->options.learned_extent_fit;
  if (classes == ExtentFitClasses::kNone) return;
  const VisibilityTest visibility = ScanVisibility(scan, image);
  ExtentFitOptions fit_options;
  fit_options.one_edge_moves = impl_->options.learned_extent_one_edge;
  size_t k = 0;
  for (DetectionDebug::Hypothesis& h : *hypotheses) {
    if (h.outcome != HypothesisOutcome::kDetected) continue;
    Require(k < detections->size(), "ExtentFitLearned: hypotheses and detections differ");
    Detection& d = (*detections)[k++];
    if (!FitsExtent(classes, d.furniture_class)) continue;
    const ExtentFit fit =
        FitExtent(image, {d.x, d.y, d.yaw, d.width, d.depth}, visibility, fit_options);
    h.extent_edges = static_cast<int>(std::count(fit.edge_seen.begin(), fit.edge_seen.end(), true));
    h.extent_moved_m = std::hypot(fit.box.x - d.x, fit.box.y - d.y);
    d.x = h.x = fit.box.x;
    d.y = h.y = fit.box.y;
    d.yaw = h.yaw = fit.box.yaw;
    d.width = h.width = fit.box.width;
    d.depth = h.depth = fit.box.depth;
  }
}

void Detector::FitLearned(const PreparedScan& scan,
                          std::vector<DetectionDebug::Hypothesis>* hypotheses,
                          std::vector<Detection>* detections) const {
  const Impl& impl = *impl_;
  std::vector<int> fitted;  // hypotheses with a detection, in detection order
  for (size_t h = 0; h < hypotheses->size(); ++h) {
    if ((*hypotheses)[h].outcome == HypothesisOutcome::kDetected)
      fitted.push_back(static_cast<int>(h));
  }
  Require(fitted.size() == detections->size(), "FitLearned: hypotheses and detections differ");
  std::vector<std::map<int, double>> supports(fitted.size());
  for (size_t k = 0; k < fitted.size(); ++k) {
    DetectionDebug::Hypothesis& hypothesis = (*hypotheses)[fitted[k]];
    supports[k] = SegmentsInBox(scan, hypothesis);
    for (const auto& [segment, weight] : supports[k]) hypothesis.segments.push_back(segment);
  }
  const std::vector<std::vector<int>> neighbours = impl.SegmentNeighbours(scan, supports);
  ParallelFor(0, static_cast<int>(fitted.size()), [&](int k) {
    DetectionDebug::Hypothesis& hypothesis = (*hypotheses)[fitted[k]];
    if (supports[k].empty()) return;
    impl.Rank(supports[k], neighbours, &hypothesis);  // with support: sets no outcome
    HypothesisFit fit = FitHypothesis(scan, hypothesis, fitted[k]);
    hypothesis.fits = std::move(fit.tried);
    if (!fit.best) return;
    const PlanarPose& pose = fit.best->fit.pose;
    hypothesis.fit_x = pose.x;
    hypothesis.fit_y = pose.y;
    if (std::hypot(pose.x - hypothesis.x, pose.y - hypothesis.y) > impl.options.learned_fit_agree_m)
      return;
    // The fit's yaw and CAD model; the network's position and footprint,
    // which protocol E measured as at least as good as the fit's (a CAD
    // model of another size, fitted to a partial view, shifts its centre).
    hypothesis.refined = true;
    Detection& d = (*detections)[k];
    d.yaw = pose.yaw;
    d.model_index = fit.best->model;
    d.model_name = impl.model.model_names[fit.best->model];
    d.verification = fit.best->verification;
    d.covered_fraction = fit.best->covered;
  });
}

std::vector<DetectionDebug::Hypothesis> Detector::LearnedMaxima(
    const BevImage& image, const BevOutput& output, std::vector<Detection>* detections) const {
  const DetectorOptions& options = impl_->options;
  std::vector<DetectionDebug::Hypothesis> hypotheses;
  for (const BevPeak& peak : DecodeBevOutput(image, output, options.LearnedDecode())) {
    DetectionDebug::Hypothesis h;
    h.learned = true;
    h.furniture_class = peak.furniture_class;
    h.x = h.fit_x = peak.x;
    h.y = h.fit_y = peak.y;
    h.vote_weight = h.relative_weight = peak.heat;
    h.yaw = peak.yaw;
    h.width = peak.width;
    h.depth = peak.depth;
    h.peak_x = peak.peak_x;
    h.peak_y = peak.peak_y;
    h.votes = peak.votes;
    h.edge_cells = peak.edge_cells;
    h.outcome = peak.suppressed ? HypothesisOutcome::kSuppressed : HypothesisOutcome::kDetected;
    h.outcome_values[0] = peak.suppressed_by_m;
    const OperatingPoint& point = impl_->operating_point;
    if (!peak.suppressed && !point.Keeps(peak.furniture_class, peak.heat)) {
      h.outcome = HypothesisOutcome::kBelowOperatingPoint;
      h.outcome_values[0] = peak.heat;
      h.outcome_values[1] = point.MinScore(peak.furniture_class);
    }
    if (h.outcome == HypothesisOutcome::kDetected) {
      Detection d;
      d.furniture_class = peak.furniture_class;
      d.x = peak.x;
      d.y = peak.y;
      d.yaw = peak.yaw;
      d.width = peak.width;
      d.depth = peak.depth;
      d.score = d.vote_weight = peak.heat;
      detections->push_back(d);
    }
    hypotheses.push_back(h);
  }
  return hypotheses;
}

void Detector::DetectLearned(const DetectionInput& input,
                             PreparedScan* prepared,
                             bool keep_debug,
                             StageTimer* timer,
                             DetectionResult* result) const {
  const Impl& impl = *impl_;
  // The network's stages (on one torch thread) beside the segmentation its
  // fits need (they share nothing): each on a core of its own. Their stage
  // times overlap.
  BevImage image;
  BevOutput output;
  StageTimings network_ms;
  auto network = [&] {
    // On the thread that runs the network: OpenMP's thread count is the
    // calling thread's.
    SetTorchThreads(impl.options.torch_threads);
    StageTimer network_timer(&network_ms);
    // The network's own range (it was trained on it), not the codebook's.
    image = RasteriseScan(prepared->camera_points,
                          prepared->world_from_camera,
                          impl.vote_net.options().range_m,
                          impl.vote_net.options().grid);
    network_timer.Lap(DetectionStage::kBev);
    output = impl.vote_net.Predict(image, impl.options.learned_mirror_average);
    network_timer.Lap(DetectionStage::kNetwork);
    result->debug.hypotheses = LearnedMaxima(image, output, &result->detections);
    network_timer.Lap(DetectionStage::kMaxima);
  };
  if (impl.options.learned_fit && impl.options.torch_threads == 1) {
    RunBeside(network, [&] { SegmentScan(input, prepared); });
  } else {  // a network on every core has none to share (measured: slower beside)
    network();
    if (impl.options.learned_fit) SegmentScan(input, prepared);
  }
  const PreparedScan& scan = *prepared;
  result->segments = static_cast<int>(scan.view.segments.size());
  std::vector<StageTime>& stages = result->timings_ms.stages;
  stages.insert(stages.end(), scan.timings_ms.stages.begin(), scan.timings_ms.stages.end());
  stages.insert(stages.end(), network_ms.stages.begin(), network_ms.stages.end());
  timer->Restart();
  if (impl.options.learned_fit) {
    FitLearned(scan, &result->debug.hypotheses, &result->detections);
    timer->Lap(DetectionStage::kFitAndVerify);
  }
  ExtentFitLearned(scan, image, &result->debug.hypotheses, &result->detections);
  timer->Total();
  result->points = scan.input_points;
  if (!keep_debug) return;
  DetectionDebug& debug = result->debug;
  for (int k = 0; k < kBevClasses; ++k)
    debug.grids.push_back(WorldGridOf(image, output, k, impl.options.learned_decode.min_heat));
  const Eigen::Isometry3f world_from_camera = scan.world_from_camera.cast<float>();
  const float max_range2 =
      static_cast<float>(impl.vote_net.options().range_m * impl.vote_net.options().range_m);
  for (const Eigen::Vector3f& p : scan.camera_points) {
    if (!p.allFinite() || p.squaredNorm() == 0 || p.squaredNorm() > max_range2) continue;
    const Eigen::Vector3f world = world_from_camera * p;
    if (world.z() >= impl.options.floor_band_m) debug.points.push_back(world);
  }
  debug.segment_of_point.assign(debug.points.size(), -1);
}

}  // namespace furn
