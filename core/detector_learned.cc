// Learned voting (issue 30): the scan's bird's-eye-view image through the
// model's vote network; the heat maps' maxima are hypotheses and, once no
// stronger maximum of any class lies within learned_suppress_m, detections
// with the network's position, yaw and footprint.
#include <algorithm>
#include <cmath>

#include "core/detector.h"
#include "core/detector_impl.h"
#include "core/error.h"

namespace furn {
namespace {

struct Peak {
  int class_index = 0, row = 0, col = 0;
  float heat = 0;
};

// Cells of one heat plane at least `min_heat` and not below any of their 8
// neighbours (of equal neighbours the first in row-major order wins).
std::vector<Peak> PeaksOf(const BevOutput& output, int class_index, double min_heat) {
  const BevGridSpec& spec = output.spec;
  std::vector<Peak> peaks;
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      const float heat = output.At(class_index, r, c);
      if (heat < min_heat) continue;
      bool peak = true;
      for (int dr = -1; dr <= 1 && peak; ++dr) {
        for (int dc = -1; dc <= 1 && peak; ++dc) {
          const int rr = r + dr, cc = c + dc;
          if ((dr == 0 && dc == 0) || rr < 0 || rr >= spec.rows || cc < 0 || cc >= spec.cols)
            continue;
          const float other = output.At(class_index, rr, cc);
          const bool earlier = dr < 0 || (dr == 0 && dc < 0);
          if (other > heat || (other == heat && earlier)) peak = false;
        }
      }
      if (peak) peaks.push_back({class_index, r, c, heat});
    }
  }
  return peaks;
}

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
  grid.values.assign(static_cast<size_t>(grid.rows) * grid.cols, 0.0f);
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const Eigen::Vector2d world = low + Eigen::Vector2d(c + 0.5, r + 0.5) * spec.cell_m;
      const Eigen::Vector2d cell = image.frame.CellOf(world, spec);
      const int row = static_cast<int>(std::floor(cell.x()));
      const int col = static_cast<int>(std::floor(cell.y()));
      if (row < 0 || row >= spec.rows || col < 0 || col >= spec.cols) continue;
      grid.values[static_cast<size_t>(r) * grid.cols + c] = output.At(class_index, row, col);
    }
  }
  return grid;
}

}  // namespace

std::vector<DetectionDebug::Hypothesis> Detector::LearnedMaxima(
    const BevImage& image, const BevOutput& output, std::vector<Detection>* detections) const {
  const DetectorOptions& options = impl_->options;
  const BevGridSpec& spec = image.spec;
  std::vector<Peak> peaks;
  for (int k = 0; k < kBevClasses; ++k) {
    std::vector<Peak> of_class = PeaksOf(output, k, options.learned_min_heat);
    std::stable_sort(of_class.begin(), of_class.end(), [](const Peak& a, const Peak& b) {
      return a.heat > b.heat;
    });
    if (of_class.size() > static_cast<size_t>(options.learned_max_per_class))
      of_class.resize(options.learned_max_per_class);
    peaks.insert(peaks.end(), of_class.begin(), of_class.end());
  }
  std::stable_sort(
      peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) { return a.heat > b.heat; });
  std::vector<DetectionDebug::Hypothesis> hypotheses;
  for (const Peak& peak : peaks) {
    const FurnitureClass furniture_class = kAllClasses[peak.class_index];
    auto regressed = [&](int j) { return output.At(kBevClasses + j, peak.row, peak.col); };
    const Eigen::Vector2d cell(peak.row + std::clamp(regressed(0), 0.0f, 1.0f),
                               peak.col + std::clamp(regressed(1), 0.0f, 1.0f));
    const Eigen::Vector2d xy = image.frame.WorldOf(cell, spec);
    DetectionDebug::Hypothesis h;
    h.furniture_class = furniture_class;
    h.x = h.fit_x = xy.x();
    h.y = h.fit_y = xy.y();
    h.vote_weight = h.relative_weight = peak.heat;
    h.width = std::exp(std::clamp(regressed(2), -3.0f, 1.5f));
    h.depth = std::exp(std::clamp(regressed(3), -3.0f, 1.5f));
    h.yaw = WrapAngle(std::atan2(regressed(5), regressed(4)) / BevYawSymmetry(furniture_class) +
                      image.frame.heading);
    h.outcome = HypothesisOutcome::kDetected;
    for (const Detection& kept : *detections) {
      const double distance = std::hypot(kept.x - h.x, kept.y - h.y);
      if (distance < options.learned_suppress_m) {
        h.outcome = HypothesisOutcome::kSuppressed;
        h.outcome_values[0] = distance;
        break;
      }
    }
    if (h.outcome == HypothesisOutcome::kDetected) {
      Detection d;
      d.furniture_class = furniture_class;
      d.x = h.x;
      d.y = h.y;
      d.yaw = h.yaw;
      d.width = h.width;
      d.depth = h.depth;
      d.score = d.vote_weight = peak.heat;
      detections->push_back(d);
    }
    hypotheses.push_back(h);
  }
  return hypotheses;
}

void Detector::DetectLearned(const PreparedScan& scan,
                             bool keep_debug,
                             StageTimer* timer,
                             DetectionResult* result) const {
  const Impl& impl = *impl_;
  SetTorchThreads(impl.options.torch_threads);
  const BevImage image = RasteriseScan(scan.camera_points,
                                       scan.world_from_camera,
                                       impl.options.max_range_m,
                                       impl.vote_net.options().grid);
  timer->Lap(DetectionStage::kBev);
  const BevOutput output = impl.vote_net.Predict(image);
  timer->Lap(DetectionStage::kNetwork);
  result->debug.hypotheses = LearnedMaxima(image, output, &result->detections);
  timer->Lap(DetectionStage::kMaxima);
  timer->Total();
  result->points = scan.input_points;
  if (!keep_debug) return;
  DetectionDebug& debug = result->debug;
  for (int k = 0; k < kBevClasses; ++k)
    debug.grids.push_back(WorldGridOf(image, output, k, impl.options.learned_min_heat));
  const Eigen::Isometry3f world_from_camera = scan.world_from_camera.cast<float>();
  const float max_range2 = static_cast<float>(impl.options.max_range_m * impl.options.max_range_m);
  for (const Eigen::Vector3f& p : scan.camera_points) {
    if (!p.allFinite() || p.squaredNorm() == 0 || p.squaredNorm() > max_range2) continue;
    const Eigen::Vector3f world = world_from_camera * p;
    if (world.z() >= impl.options.floor_band_m) debug.points.push_back(world);
  }
  debug.segment_of_point.assign(debug.points.size(), -1);
}

}  // namespace furn
