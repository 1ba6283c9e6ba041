#include "core/detector/learned_source.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include "core/detector/detector_impl.h"
#include "core/geometry/render_compare.h"
#include "core/util/error.h"
#include "core/util/parallel.h"

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
  const double half_w = hypothesis.width / 2 + kSupportMarginM;
  const double half_d = hypothesis.depth / 2 + kSupportMarginM;
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

LearnedSource::LearnedSource(const Detector& detector) : detector_(detector) {
  Require(detector.learned(),
          "LearnedSource: the detector does not vote with a network (voting codebook, or none in "
          "the model)");
}

void LearnedSource::FitExtents(const PreparedScan& scan, Proposals* proposals) const {
  const DetectorOptions& options = detector_.options();
  const ExtentFitClasses classes = options.learned_extent_fit;
  if (classes == ExtentFitClasses::kNone) return;
  const VisibilityTest visibility = ScanVisibility(scan, proposals->image);
  ExtentFitOptions fit_options;
  fit_options.one_edge_moves = options.learned_extent_one_edge;
  for (Candidate& candidate : proposals->candidates) {
    Detection& d = candidate.detection;
    if (!FitsExtent(classes, d.furniture_class)) continue;
    DetectionDebug::Hypothesis& h = proposals->hypotheses[candidate.hypothesis];
    DetectionDebug::LearnedPeak& peak = *h.learned;
    const ExtentFit fit = FitExtent(proposals->image, d.box(), visibility, fit_options);
    peak.extent_edges =
        static_cast<int>(std::count(fit.edge_seen.begin(), fit.edge_seen.end(), true));
    peak.extent_moved_m = std::hypot(fit.box.x - d.x, fit.box.y - d.y);
    d.box() = h.box() = fit.box;
  }
}

void LearnedSource::FitCandidates(const PreparedScan& scan, Proposals* proposals) const {
  const Detector::Impl& impl = *detector_.impl_;
  std::vector<Candidate>& candidates = proposals->candidates;
  std::vector<std::map<int, double>> supports(candidates.size());
  for (size_t k = 0; k < candidates.size(); ++k) {
    DetectionDebug::Hypothesis& hypothesis = proposals->hypotheses[candidates[k].hypothesis];
    supports[k] = SegmentsInBox(scan, hypothesis);
    for (const auto& [segment, weight] : supports[k]) hypothesis.segments.push_back(segment);
  }
  const std::vector<std::vector<int>> neighbours = impl.SegmentNeighbours(scan, supports);
  std::vector<int> supported, indices;  // the candidates with support, and their hypotheses
  for (size_t k = 0; k < candidates.size(); ++k) {
    if (supports[k].empty()) continue;
    supported.push_back(static_cast<int>(k));
    indices.push_back(candidates[k].hypothesis);
  }
  ParallelFor(0, static_cast<int>(supported.size()), [&](int s) {
    // With support, Rank sets no outcome.
    impl.Rank(supports[supported[s]], neighbours, &proposals->hypotheses[indices[s]]);
  });
  std::vector<HypothesisFit> fits = detector_.FitHypotheses(scan, proposals->hypotheses, indices);
  for (size_t s = 0; s < supported.size(); ++s) {
    const int k = supported[s];
    DetectionDebug::Hypothesis& hypothesis = proposals->hypotheses[indices[s]];
    HypothesisFit& fit = fits[s];
    hypothesis.fits = std::move(fit.tried);
    if (!fit.best) continue;
    const PlanarPose& pose = fit.best->fit.pose;
    hypothesis.fit_x = pose.x;
    hypothesis.fit_y = pose.y;
    if (std::hypot(pose.x - hypothesis.x, pose.y - hypothesis.y) > impl.options.learned_fit_agree_m)
      continue;
    // The fit's yaw and CAD model; the network's position and footprint,
    // which protocol E measured as at least as good as the fit's (a CAD
    // model of another size, fitted to a partial view, shifts its centre).
    hypothesis.learned->refined = true;
    Detection& d = candidates[k].detection;
    d.yaw = pose.yaw;
    d.model_index = fit.best->model;
    d.model_name = impl.model.model_names[fit.best->model];
    d.verification = fit.best->verification;
    d.covered_fraction = fit.best->covered;
  }
}

Detection LearnedSource::DetectionOf(const BevPeak& peak) {
  Detection d;
  d.box() = peak.box();
  d.furniture_class = peak.furniture_class;
  d.score = d.vote_weight = peak.heat;
  return d;
}

Proposals LearnedSource::Decode(const BevImage& image, const BevOutput& output) const {
  Proposals proposals;
  for (const BevPeak& peak : DecodeBevOutput(image, output, detector_.options().LearnedDecode())) {
    DetectionDebug::Hypothesis h;
    h.box() = peak.box();
    h.furniture_class = peak.furniture_class;
    h.fit_x = peak.x;
    h.fit_y = peak.y;
    h.vote_weight = h.relative_weight = peak.heat;
    DetectionDebug::LearnedPeak& record = h.learned.emplace();
    record.peak_x = peak.peak_x;
    record.peak_y = peak.peak_y;
    record.votes = peak.votes;
    record.edge_cells = peak.edge_cells;
    record.suppressed_by_m = peak.suppressed_by_m;
    h.outcome = peak.suppressed ? HypothesisOutcome::kSuppressed : HypothesisOutcome::kDetected;
    if (!peak.suppressed) {
      Candidate candidate;
      candidate.detection = DetectionOf(peak);
      candidate.hypothesis = static_cast<int>(proposals.hypotheses.size());
      proposals.candidates.push_back(std::move(candidate));
    }
    proposals.hypotheses.push_back(std::move(h));
  }
  return proposals;
}

BevImage LearnedSource::Rasterise(const PreparedScan& scan) const {
  const VoteNet& vote_net = detector_.impl_->vote_net;
  return RasteriseScan(scan.camera_points,
                       scan.world_from_camera,
                       vote_net.options().range_m,
                       vote_net.options().grid);
}

BevOutput LearnedSource::RunNetwork(const BevImage& image) const {
  return detector_.impl_->vote_net.Predict(image, detector_.options().learned_mirror_average);
}

Proposals LearnedSource::Propose(const DetectionInput& input,
                                 PreparedScan* prepared,
                                 bool /*keep_debug*/,
                                 StageTimer* timer,
                                 DetectionResult* result) const {
  const DetectorOptions& options = detector_.options();
  // The network's stages (on one torch thread) beside the segmentation its
  // fits need (they share nothing): each on a core of its own. Their stage
  // times overlap.
  Proposals proposals;
  StageTimings network_ms;
  auto network = [&] {
    // On the thread that runs the network: OpenMP's thread count is the
    // calling thread's.
    SetTorchThreads(options.torch_threads);
    StageTimer network_timer(&network_ms);
    BevImage image = Rasterise(*prepared);
    network_timer.Lap(DetectionStage::kBev);
    BevOutput output = RunNetwork(image);
    network_timer.Lap(DetectionStage::kNetwork);
    proposals = Decode(image, output);
    proposals.image = std::move(image);
    proposals.output = std::move(output);
    network_timer.Lap(DetectionStage::kMaxima);
  };
  if (options.learned_fit && options.torch_threads == 1) {
    // The branch that ends first keeps the depth image and builds the
    // occupancy grid.
    OccupancyHandoff handoff;
    double depth_image_ms = 0;
    RunBeside(
        [&] {
          network();
          // The depth image and the grid beside region growing, not the MLS.
          handoff.WaitUntilPreprocessed();
          if (handoff.ClaimDepthImage()) {
            const auto start = std::chrono::steady_clock::now();
            KeepDepthImage(input, options.max_range_m, prepared);
            depth_image_ms =
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                    .count();
          }
          handoff.BuildIfFree(&network_ms);
        },
        [&] { detector_.SegmentScan(input, prepared, &handoff); });
    prepared->occupancy = handoff.Take();
    // The depth image's time is the segment stage's, as in SegmentScan.
    for (StageTime& stage : prepared->timings_ms.stages) {
      if (stage.stage == DetectionStage::kSegment) stage.ms += depth_image_ms;
    }
  } else {  // a network on every core has none to share (measured: slower beside)
    network();
    if (options.learned_fit) detector_.SegmentScan(input, prepared);
  }
  const PreparedScan& scan = *prepared;
  std::vector<StageTime>& stages = result->timings_ms.stages;
  stages.insert(stages.end(), scan.timings_ms.stages.begin(), scan.timings_ms.stages.end());
  stages.insert(stages.end(), network_ms.stages.begin(), network_ms.stages.end());
  timer->Restart();
  return proposals;
}

void LearnedSource::Refine(const PreparedScan& scan,
                           Proposals* proposals,
                           StageTimer* timer) const {
  if (detector_.options().learned_fit) {
    FitCandidates(scan, proposals);
    timer->Lap(DetectionStage::kFitAndVerify);
  }
  FitExtents(scan, proposals);
}

void LearnedSource::Record(const PreparedScan& scan,
                           Proposals* proposals,
                           DetectionDebug* debug) const {
  const DetectorOptions& options = detector_.options();
  for (int k = 0; k < kBevClasses; ++k) {
    debug->grids.push_back(
        WorldGridOf(proposals->image, proposals->output, k, options.learned_decode.min_heat));
  }
  const Eigen::Isometry3f world_from_camera = scan.world_from_camera.cast<float>();
  const double range_m = detector_.impl_->vote_net.options().range_m;
  const float max_range2 = static_cast<float>(range_m * range_m);
  for (const Eigen::Vector3f& p : scan.camera_points) {
    if (!p.allFinite() || p.squaredNorm() == 0 || p.squaredNorm() > max_range2) continue;
    const Eigen::Vector3f world = world_from_camera * p;
    if (world.z() >= options.floor_band_m) debug->points.push_back(world);
  }
  debug->segment_of_point.assign(debug->points.size(), -1);
}

}  // namespace furn
