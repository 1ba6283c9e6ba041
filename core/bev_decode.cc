#include "core/bev_decode.h"

#include <algorithm>
#include <cmath>

#include "core/pose_fit.h"

namespace furn {
namespace {

struct Cell {
  int class_index = 0, row = 0, col = 0;
  float heat = 0;
};

// Cells of one heat plane at least `min_heat` and not below any of their 8
// neighbours (of equal neighbours the first in row-major order wins).
std::vector<Cell> MaximaOf(const BevOutput& output, int class_index, double min_heat) {
  const BevGridSpec& spec = output.spec;
  std::vector<Cell> maxima;
  for (int r = 0; r < spec.rows; ++r) {
    for (int c = 0; c < spec.cols; ++c) {
      const float heat = output.At(class_index, r, c);
      if (heat < min_heat) continue;
      bool maximum = true;
      for (int dr = -1; dr <= 1 && maximum; ++dr) {
        for (int dc = -1; dc <= 1 && maximum; ++dc) {
          const int rr = r + dr, cc = c + dc;
          if ((dr == 0 && dc == 0) || rr < 0 || rr >= spec.rows || cc < 0 || cc >= spec.cols)
            continue;
          const float other = output.At(class_index, rr, cc);
          const bool earlier = dr < 0 || (dr == 0 && dc < 0);
          if (other > heat || (other == heat && earlier)) maximum = false;
        }
      }
      if (maximum) maxima.push_back({class_index, r, c, heat});
    }
  }
  return maxima;
}

bool Stronger(const Cell& a, const Cell& b) { return a.heat > b.heat; }

}  // namespace

std::vector<BevPeak> DecodeBevOutput(const BevImage& image,
                                     const BevOutput& output,
                                     const BevDecodeOptions& options) {
  std::vector<Cell> cells;
  for (int k = 0; k < kBevClasses; ++k) {
    std::vector<Cell> of_class = MaximaOf(output, k, options.min_heat);
    std::stable_sort(of_class.begin(), of_class.end(), Stronger);
    if (of_class.size() > static_cast<size_t>(options.max_per_class))
      of_class.resize(options.max_per_class);
    cells.insert(cells.end(), of_class.begin(), of_class.end());
  }
  std::stable_sort(cells.begin(), cells.end(), Stronger);
  std::vector<BevPeak> peaks;
  for (const Cell& cell : cells) {
    auto regressed = [&](int j) { return output.At(kBevClasses + j, cell.row, cell.col); };
    BevPeak peak;
    peak.furniture_class = kAllClasses[cell.class_index];
    const Eigen::Vector2d at(cell.row + std::clamp(regressed(0), 0.0f, 1.0f),
                             cell.col + std::clamp(regressed(1), 0.0f, 1.0f));
    const Eigen::Vector2d xy = image.frame.WorldOf(at, output.spec);
    peak.x = xy.x();
    peak.y = xy.y();
    peak.width = std::exp(std::clamp(regressed(2), -3.0f, 1.5f));
    peak.depth = std::exp(std::clamp(regressed(3), -3.0f, 1.5f));
    peak.yaw =
        WrapAngle(std::atan2(regressed(5), regressed(4)) / BevYawSymmetry(peak.furniture_class) +
                  image.frame.heading);
    peak.heat = cell.heat;
    for (const BevPeak& kept : peaks) {
      const double distance = std::hypot(kept.x - peak.x, kept.y - peak.y);
      if (!kept.suppressed && distance < options.suppress_m) {
        peak.suppressed = true;
        peak.suppressed_by_m = distance;
        break;
      }
    }
    peaks.push_back(peak);
  }
  return peaks;
}

}  // namespace furn
