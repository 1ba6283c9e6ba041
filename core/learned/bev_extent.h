// The extent fit of a learned detection: its box moved to the surface the
// scan shows (issue 37). The network places a table's centre from local
// evidence, and a cell at one end of a 2 m top cannot tell how far the other
// end is: protocol E measured long tables 16 cm off along their length,
// 5 cm across it (docs/learned-voting.md). The extent of the top itself is
// local evidence at any length: each edge lies where the surface ends.
//
// In the box's frame, the occupied cells of the BEV
// image whose highest point lies near the top's height (the median height
// of the cells in the box's inner half) and that connect to the inner half
// form the surface; each of its four edges is placed at a robust extreme of
// the cells (half a row's worth of stray cells left out), along the axes of
// the surface's smallest bounding rectangle where that is clearly smaller
// than the one along the network's yaw (a yaw 20 degrees off spoils every
// extent; the rectangle keeps the network's aspect). An edge counts
// only where the scan *saw* that the surface ends there — free space just
// beyond it at the top's height (`VisibilityTest`, e.g. a depth image's ray
// passing beyond that point), and the surface not cut by the search window.
// Per axis: both edges seen, the box spans them; one seen, the box keeps the
// network's size (or the surface's, when longer) from that edge; none, the
// network's centre stays.
//
//   const ExtentFit fit = FitExtent(image, box, visibility, ExtentFitOptions{});
//   if (fit.moved) { detection.x = fit.box.x; ... }
#pragma once

#include <Eigen/Core>
#include <array>
#include <functional>

#include "core/geometry/visibility.h"
#include "core/learned/bev_grid.h"
#include "core/model/furniture_box.h"
#include "core/util/enum_text.h"

namespace furn {

// The BEV image's own test, for scans without a depth image: a point is
// occupied where its cell's highest point reaches its height, else free
// where the cell lies nearer than its bearing's farthest return (lenient: it
// cannot tell a shadow from free space), else unknown.
Visibility BevVisibility(const BevImage& image, const Eigen::Vector3d& world);

struct ExtentFitOptions {
  // The surface: cells whose highest point lies this far below (m) or above
  // the top's height still belong to it (objects standing on a table do).
  double below_top_m = 0.1;
  double above_top_m = 0.5;
  // The search window: the network's footprint times window_scale, plus
  // window_margin_m on every side (a table the network thinks 1.2 m long may
  // be 2 m).
  double window_scale = 2.0;
  double window_margin_m = 0.2;
  // Probes of free space beyond an edge: this far out (m), at the top's
  // height; an edge is seen when at least min_known of them say anything
  // (not kUnknown) and at least min_free of those are free.
  double probe_m = 0.08;
  double min_free = 0.6;
  int min_known = 2;
  int probes_per_edge = 7;
  // The box's yaw from the surface: the turn of its smallest bounding
  // rectangle, where that is at least min_area_gain smaller than the box's
  // own (a tilted network yaw makes every extent wrong).
  bool fit_yaw = true;
  double min_area_gain = 0.05;
  // An axis with one edge seen: the box keeps the network's size from that
  // edge (true), or the axis stays the network's (false: only an axis with
  // both edges seen moves).
  bool one_edge_moves = true;

  // Throws InputError naming the field and the rule.
  void Check() const;
};

struct ExtentFit {
  FurnitureBox box;                 // the refined box (the network's where nothing moved)
  bool moved = false;               // at least one axis was refined
  std::array<bool, 4> edge_seen{};  // +width, -width, +depth, -depth sides
  int surface_cells = 0;
  double top_m = 0;  // the surface's height
};

ExtentFit FitExtent(const BevImage& image,
                    const FurnitureBox& network_box,
                    const VisibilityTest& visibility,
                    const ExtentFitOptions& options);

// Which classes' detections are refined by their extent.
enum class ExtentFitClasses { kNone, kTables, kLarge, kAll };
template <>
struct EnumText<ExtentFitClasses> {
  static constexpr const char* kKind = "extent fit";
  static constexpr EnumEntry<ExtentFitClasses> kEntries[] = {
      {ExtentFitClasses::kNone, "none"},
      {ExtentFitClasses::kTables, "tables"},
      {ExtentFitClasses::kLarge, "large"},  // tables, sideboards and sofas
      {ExtentFitClasses::kAll, "all"},
  };
};
bool FitsExtent(ExtentFitClasses classes, FurnitureClass furniture_class);

}  // namespace furn
