#include "core/learned/bev_extent.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/util/error.h"

namespace furn {
namespace {

// A cell of the window in the box's frame.
struct LocalCell {
  int row = 0, col = 0;
  Eigen::Vector2d local = Eigen::Vector2d::Zero();  // (along width, along depth), m
  double top_m = 0;                                 // its highest point
  bool occupied = false;
};

// The box's frame: local = R(-yaw) (world - centre).
struct BoxFrame {
  Eigen::Vector2d centre;
  Eigen::Vector2d axis_w, axis_d;

  explicit BoxFrame(const FurnitureBox& box)
      : centre(box.x, box.y),
        axis_w(std::cos(box.yaw), std::sin(box.yaw)),
        axis_d(-std::sin(box.yaw), std::cos(box.yaw)) {}
  Eigen::Vector2d Local(const Eigen::Vector2d& world) const {
    const Eigen::Vector2d d = world - centre;
    return {d.dot(axis_w), d.dot(axis_d)};
  }
  Eigen::Vector2d World(const Eigen::Vector2d& local) const {
    return centre + axis_w * local.x() + axis_d * local.y();
  }
};

// The window's cells (row-major over the rows and columns it touches).
std::vector<LocalCell> WindowCells(const BevImage& image,
                                   const BoxFrame& frame,
                                   const Eigen::Vector2d& half_window) {
  const BevGridSpec& spec = image.spec;
  Eigen::Vector2d low(1e30, 1e30), high(-1e30, -1e30);
  for (const double sw : {-1.0, 1.0}) {
    for (const double sd : {-1.0, 1.0}) {
      const Eigen::Vector2d corner =
          image.frame.CellOf(frame.World({sw * half_window.x(), sd * half_window.y()}), spec);
      low = low.cwiseMin(corner);
      high = high.cwiseMax(corner);
    }
  }
  std::vector<LocalCell> cells;
  const int r0 = std::max(0, static_cast<int>(std::floor(low.x())));
  const int r1 = std::min(spec.rows - 1, static_cast<int>(std::floor(high.x())));
  const int c0 = std::max(0, static_cast<int>(std::floor(low.y())));
  const int c1 = std::min(spec.cols - 1, static_cast<int>(std::floor(high.y())));
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      LocalCell cell;
      cell.row = r;
      cell.col = c;
      cell.local = frame.Local(image.frame.WorldOf({r + 0.5, c + 0.5}, spec));
      if (std::abs(cell.local.x()) > half_window.x() || std::abs(cell.local.y()) > half_window.y())
        continue;
      cell.occupied = image.Occupied(r, c);
      cell.top_m = 2.0 * image.At(kBevTopChannel, r, c);
      cells.push_back(cell);
    }
  }
  return cells;
}

bool InInnerHalf(const LocalCell& cell, const FurnitureBox& box, double cell_m) {
  return std::abs(cell.local.x()) <= box.width / 4 + cell_m &&
         std::abs(cell.local.y()) <= box.depth / 4 + cell_m;
}

// The median top height of the occupied cells in the box's inner half; < 0
// when there are none.
double TopHeight(const std::vector<LocalCell>& cells, const FurnitureBox& box, double cell_m) {
  std::vector<double> tops;
  for (const LocalCell& cell : cells) {
    if (cell.occupied && InInnerHalf(cell, box, cell_m)) tops.push_back(cell.top_m);
  }
  if (tops.empty()) return -1;
  const auto middle = tops.begin() + static_cast<std::ptrdiff_t>(tops.size() / 2);
  std::nth_element(tops.begin(), middle, tops.end());
  return *middle;
}

// The surface: cells near the top's height, 8-connected to those in the
// inner half. Indices into `cells`.
std::vector<int> SurfaceCells(const std::vector<LocalCell>& cells,
                              const FurnitureBox& box,
                              double top_m,
                              const BevGridSpec& spec,
                              const ExtentFitOptions& options) {
  std::vector<int> index_of(static_cast<size_t>(spec.rows) * spec.cols, -1);
  std::vector<char> candidate(cells.size(), 0), reached(cells.size(), 0);
  std::vector<int> stack;
  for (size_t i = 0; i < cells.size(); ++i) {
    const LocalCell& cell = cells[i];
    index_of[static_cast<size_t>(cell.row) * spec.cols + cell.col] = static_cast<int>(i);
    candidate[i] = cell.occupied && cell.top_m >= top_m - options.below_top_m &&
                   cell.top_m <= top_m + options.above_top_m;
    if (candidate[i] && InInnerHalf(cell, box, spec.cell_m)) {
      reached[i] = 1;
      stack.push_back(static_cast<int>(i));
    }
  }
  std::vector<int> surface;
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    surface.push_back(i);
    for (int dr = -1; dr <= 1; ++dr) {
      for (int dc = -1; dc <= 1; ++dc) {
        const int r = cells[i].row + dr, c = cells[i].col + dc;
        if (r < 0 || r >= spec.rows || c < 0 || c >= spec.cols) continue;
        const int j = index_of[static_cast<size_t>(r) * spec.cols + c];
        if (j < 0 || !candidate[j] || reached[j]) continue;
        reached[j] = 1;
        stack.push_back(j);
      }
    }
  }
  std::sort(surface.begin(), surface.end());  // the fill's order is no result
  return surface;
}

// The extreme of `values` on one side, leaving out half a row's worth of
// stray cells (a row of the surface across this axis holds about
// values.size() / rows cells).
double RobustExtreme(std::vector<double> values, bool upper, double cell_m) {
  std::sort(values.begin(), values.end());
  const double span = values.back() - values.front();
  const double rows = std::max(1.0, span / cell_m + 1);
  const size_t skip = static_cast<size_t>(0.5 * static_cast<double>(values.size()) / rows);
  return upper ? values[values.size() - 1 - skip] : values[skip];
}

// Whether the scan saw free space just beyond the edge at `edge` along
// `axis` (0: width, 1: depth; sign: which side), across the surface's
// extent `across` on the other axis.
bool EdgeSeen(const BoxFrame& frame,
              int axis,
              double edge,
              double sign,
              const std::array<double, 2>& across,
              double top_m,
              const VisibilityTest& visibility,
              const ExtentFitOptions& options) {
  int free = 0, known = 0;
  for (int k = 0; k < options.probes_per_edge; ++k) {
    const double t = (k + 0.5) / options.probes_per_edge;
    Eigen::Vector2d local;
    local[axis] = edge + sign * options.probe_m;
    local[1 - axis] = across[0] + t * (across[1] - across[0]);
    const Eigen::Vector2d xy = frame.World(local);
    const Visibility seen = visibility(Eigen::Vector3d(xy.x(), xy.y(), top_m));
    free += seen == Visibility::kFree;
    known += seen != Visibility::kUnknown;
  }
  return known >= options.min_known && free >= options.min_free * known;
}

// One axis refined: the new centre offset and size along it, from the
// surface's extent [low, high] and which of its edges were seen.
void RefineAxis(
    double low, double high, bool low_seen, bool high_seen, double* centre, double* size) {
  const double extent = high - low;
  if (low_seen && high_seen) {
    *centre = (low + high) / 2;
    *size = extent;
  } else if (high_seen) {
    *size = std::max(*size, extent);
    *centre = high - *size / 2;
  } else if (low_seen) {
    *size = std::max(*size, extent);
    *centre = low + *size / 2;
  }
}

}  // namespace

Visibility BevVisibility(const BevImage& image, const Eigen::Vector3d& world) {
  const Eigen::Vector2d cell = image.frame.CellOf(world.head<2>(), image.spec);
  const int row = static_cast<int>(std::floor(cell.x()));
  const int col = static_cast<int>(std::floor(cell.y()));
  if (row < 0 || row >= image.spec.rows || col < 0 || col >= image.spec.cols)
    return Visibility::kUnknown;
  // A cell whose highest point lies below the height asked about is free
  // there when the sensor saw the cell (a chair's seat beside a table's top).
  constexpr double kBelowM = 0.05;
  if (image.Occupied(row, col) && 2.0 * image.At(kBevTopChannel, row, col) >= world.z() - kBelowM)
    return Visibility::kOccupied;
  return image.At(kBevSeenChannel, row, col) > 0.5f ? Visibility::kFree : Visibility::kUnknown;
}

void ExtentFitOptions::Check() const {
  Require(below_top_m >= 0 && below_top_m <= 1 && above_top_m >= 0 && above_top_m <= 2,
          "extent fit height band must be 0..1 m below and 0..2 m above the top");
  Require(window_scale >= 1 && window_scale <= 4,
          "extent fit window scale " + std::to_string(window_scale) + " must be in 1..4");
  Require(window_margin_m >= 0 && window_margin_m <= 2,
          "extent fit window margin " + std::to_string(window_margin_m) + " m must be in 0..2");
  Require(probe_m > 0 && probe_m <= 1,
          "extent fit probe " + std::to_string(probe_m) + " m must be in (0, 1]");
  Require(min_free > 0 && min_free <= 1,
          "extent fit least free fraction " + std::to_string(min_free) + " must be in (0, 1]");
  Require(min_area_gain >= 0 && min_area_gain < 1,
          "extent fit least area gain " + std::to_string(min_area_gain) + " must be in 0..1");
  Require(probes_per_edge >= 1 && probes_per_edge <= 100,
          "extent fit probes per edge must be in 1..100");
  Require(min_known >= 1 && min_known <= probes_per_edge,
          "extent fit least known probes " + std::to_string(min_known) +
              " must be in 1..probes per edge");
}

namespace {

// The surface a box lies on: the window's cells, the top's height and the
// surface's cells among them (empty when there is none).
struct Surface {
  Eigen::Vector2d half_window = Eigen::Vector2d::Zero();
  std::vector<LocalCell> cells;
  std::vector<int> members;
  double top_m = -1;
};

Surface SurfaceOf(const BevImage& image, const FurnitureBox& box, const ExtentFitOptions& options) {
  Surface surface;
  surface.half_window = Eigen::Vector2d(box.width, box.depth) * (options.window_scale / 2) +
                        Eigen::Vector2d::Constant(options.window_margin_m);
  surface.cells = WindowCells(image, BoxFrame(box), surface.half_window);
  surface.top_m = TopHeight(surface.cells, box, image.spec.cell_m);
  if (surface.top_m >= 0)
    surface.members = SurfaceCells(surface.cells, box, surface.top_m, image.spec, options);
  return surface;
}

// The side lengths (along, across) of the surface's robust bounding
// rectangle turned by `angle` from the box's axes, each cell counted whole.
Eigen::Vector2d TurnedLengths(const Surface& surface, double angle, double cell_m) {
  const double c = std::cos(angle), s = std::sin(angle);
  std::vector<double> along, across;
  for (int i : surface.members) {
    const Eigen::Vector2d& p = surface.cells[i].local;
    along.push_back(c * p.x() + s * p.y());
    across.push_back(-s * p.x() + c * p.y());
  }
  return {RobustExtreme(along, true, cell_m) - RobustExtreme(along, false, cell_m) + cell_m,
          RobustExtreme(across, true, cell_m) - RobustExtreme(across, false, cell_m) + cell_m};
}

// The yaw of the surface's smallest bounding rectangle (search-based
// rectangle fitting by the area criterion), turned by quarter turns to keep
// the box's aspect (its width the longer side when it was) and nearest the
// box's yaw; the box's yaw when no turn shrinks the rectangle by
// options.min_area_gain (a round top has no yaw).
double SurfaceYaw(const Surface& surface,
                  const FurnitureBox& box,
                  double cell_m,
                  const ExtentFitOptions& options) {
  constexpr int kSteps = 90;  // 1 degree over a quarter turn
  const double unturned = TurnedLengths(surface, 0, cell_m).prod();
  double best_angle = 0, best_area = unturned;
  for (int k = -kSteps / 2; k < kSteps / 2; ++k) {
    const double angle = k * (M_PI / 2) / kSteps;
    const double area = TurnedLengths(surface, angle, cell_m).prod();
    if (area < best_area) {
      best_area = area;
      best_angle = angle;
    }
  }
  if (best_area > (1 - options.min_area_gain) * unturned) return box.yaw;
  // Keep the box's aspect where it has a clear one: is its width the longer side?
  constexpr double kClearAspect = 1.15;
  const double aspect = box.width / std::max(box.depth, 1e-6);
  if (aspect > kClearAspect || aspect < 1 / kClearAspect) {
    const Eigen::Vector2d lengths = TurnedLengths(surface, best_angle, cell_m);
    if ((lengths.x() > lengths.y()) != (aspect > 1))
      best_angle += best_angle >= 0 ? -M_PI / 2 : M_PI / 2;
  }
  return box.yaw + best_angle;
}

}  // namespace

ExtentFit FitExtent(const BevImage& image,
                    const FurnitureBox& network_box,
                    const VisibilityTest& visibility,
                    const ExtentFitOptions& options) {
  options.Check();
  ExtentFit fit;
  fit.box = network_box;
  const double cell_m = image.spec.cell_m;
  constexpr size_t kLeastCells = 4;
  FurnitureBox box = network_box;
  Surface surface = SurfaceOf(image, box, options);
  if (options.fit_yaw && surface.members.size() >= kLeastCells) {
    const double yaw = SurfaceYaw(surface, box, cell_m, options);
    if (yaw != box.yaw) {
      box.yaw = yaw;
      surface = SurfaceOf(image, box, options);
    }
  }
  fit.top_m = surface.top_m;
  fit.surface_cells = static_cast<int>(surface.members.size());
  if (surface.members.size() < kLeastCells) return fit;
  const BoxFrame frame(box);
  std::array<double, 2> low{}, high{};
  for (int axis = 0; axis < 2; ++axis) {
    std::vector<double> values;
    for (int i : surface.members) values.push_back(surface.cells[i].local[axis]);
    low[axis] = RobustExtreme(values, false, cell_m);
    high[axis] = RobustExtreme(values, true, cell_m);
  }
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  std::array<double, 2> size = {box.width, box.depth};
  for (int axis = 0; axis < 2; ++axis) {
    // An edge at the window's border is where the search stopped, not
    // where the surface ends.
    const double border = surface.half_window[axis] - cell_m;
    const std::array<double, 2> across = {low[1 - axis], high[1 - axis]};
    const bool high_seen =
        high[axis] < border &&
        EdgeSeen(frame, axis, high[axis], +1, across, fit.top_m, visibility, options);
    const bool low_seen =
        low[axis] > -border &&
        EdgeSeen(frame, axis, low[axis], -1, across, fit.top_m, visibility, options);
    fit.edge_seen[2 * axis] = high_seen;
    fit.edge_seen[2 * axis + 1] = low_seen;
    if (!options.one_edge_moves && low_seen != high_seen) continue;
    RefineAxis(low[axis], high[axis], low_seen, high_seen, &centre[axis], &size[axis]);
    fit.moved = fit.moved || low_seen || high_seen;
  }
  if (!fit.moved) return fit;  // the network's box, yaw included
  const Eigen::Vector2d xy = frame.World(centre);
  fit.box.x = xy.x();
  fit.box.y = xy.y();
  fit.box.yaw = box.yaw;
  fit.box.width = std::max(size[0], cell_m);
  fit.box.depth = std::max(size[1], cell_m);
  return fit;
}

bool FitsExtent(ExtentFitClasses classes, FurnitureClass furniture_class) {
  switch (classes) {
    case ExtentFitClasses::kNone:
      return false;
    case ExtentFitClasses::kAll:
      return true;
    case ExtentFitClasses::kTables:
      return furniture_class == FurnitureClass::kTable;
    case ExtentFitClasses::kLarge:
      return furniture_class == FurnitureClass::kTable ||
             furniture_class == FurnitureClass::kSideboard ||
             furniture_class == FurnitureClass::kSofa;
  }
  return false;
}

}  // namespace furn
