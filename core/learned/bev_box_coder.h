// The box coder of the learned vote map (issue 37): the one place that says
// what the network's output channels (bev_channels.h) mean, in both
// directions. EncodeBevTargets turns labelled objects into what the network
// should output; DecodeBevOutput turns its output into detections. The two
// share the helpers below, so a change of encoding cannot leave the decoding
// behind.
//
// Encoding (CenterNet's heat map; with dense_votes, VoteNet's dense votes
// on the grid):
//   heat        per class, a Gaussian on each target's centre cell, 1 at the
//               cell: its width from the footprint (issue 30, the default) or
//               fixed (heat_sigma_cells);
//   votes       the centre cell regresses the box (offset to the centre, log
//               footprint, yaw); with dense_votes every occupied cell inside a
//               target's footprint (widened by vote_margin_m; the nearest
//               centre wins where two overlap) does, with membership 1;
//   ignore      with ignore_radius_cells > 0, around an object seen too little
//               to be a target, no heat or membership loss within that radius;
//   edges       with edge_votes, every occupied cell inside a target's
//               footprint (the nearest centre wins) regresses its distances to
//               the four sides of the footprint's bounding box in the grid,
//               with membership 1.
//
// Decoding: per class, 3 x 3 local maxima of the heat of at least min_heat,
// the strongest max_per_class. A maximum's centre is either its own cell's
// vote (kPeak; always for a network trained without dense votes) or the mean
// shift of the votes of the occupied cells around it,
// weighted by membership (kVotes: a partly seen table top is hundreds of cells
// agreeing on one centre); footprint and yaw likewise. Cross-class
// suppression (a weaker maximum of any class within suppress_m of a stronger
// one is marked) is optional; evaluation ranks every maximum. A weaker
// maximum of the same class within same_class_m of a stronger one is
// dropped (one object seen twice). With edge
// votes and edge_classes, a maximum of those classes is centred between its
// box's four sides, each side placed by the cells nearest it (a long table's
// far end by the cells at that end, not by its centre cell's guess).
//
//   const BevTargets targets = EncodeBevTargets(objects, image, BevCoderOptions{});
//   for (const BevPeak& p : DecodeBevOutput(image, output, BevDecodeOptions{})) ...
#pragma once

#include <limits>
#include <vector>

#include "core/learned/bev_channels.h"
#include "core/learned/bev_grid.h"
#include "core/util/enum_text.h"

namespace furn {

// The rotational symmetry the yaw is learnt modulo: 2 for tables (a
// rectangle's two ends look alike), 1 for the rest (a front).
int BevYawSymmetry(FurnitureClass furniture_class);

// How targets are encoded. The defaults are issue 30's encoding (the
// product's: on protocol E the dense one gained tables but lost chairs, and
// lost on the real set; docs/learned-voting.md); Dense() is issue 37's.
struct BevCoderOptions {
  // The centre heat's Gaussian (cells); 0: from the footprint (1-3 cells,
  // BevSplatSigma).
  double heat_sigma_cells = 0;
  // Dense votes: every occupied cell of a target votes (offset, size, yaw,
  // membership 1); false: the centre cell alone regresses the box.
  bool dense_votes = false;
  double vote_margin_m = 0.05;  // a target's cells: its footprint widened by this (m)
  // No heat or membership loss this near an object that is no target
  // (cells); 0: such objects are left out.
  double ignore_radius_cells = 0;
  // Edge votes: every occupied cell of a target regresses its distances to
  // the sides of its footprint's box (bev_channels::kEdges; four more output
  // channels).
  bool edge_votes = false;
  // Without dense votes: the cells within this distance of a target's centre
  // cell (cells; the nearest centre wins) regress its box as the centre cell
  // does, so a heat peak a cell or two off the centre still carries a trained
  // vote for it (TTFNet's regression area; 0: the centre cell alone).
  double centre_radius_cells = 0;

  int Channels() const { return bev_channels::CountOf(edge_votes); }
  // Issue 37's encoding: fixed heat width 1.5 cells, dense votes, ignore
  // regions of 3 cells.
  static BevCoderOptions Dense();
  // Throws InputError naming the field and the rule.
  void Check() const;
  bool operator==(const BevCoderOptions& other) const;
};

// The footprint-scaled heat sigma (cells) of issue 30: a sixth of the
// footprint's smaller side, 1 to 3 cells.
double BevSplatSigma(double width_m, double depth_m, const BevGridSpec& spec);

// `channels` (BevCoderOptions::Channels) x rows x cols of targets, and per
// cell (rows x cols) where the regressions count (`votes`: 1 on a target's
// occupied cells), how much the heat and membership losses count (`weight`:
// 0 in ignore regions, else 1) and, with edge votes, where the edge
// distances count (`edges`: 1 on a target's occupied cells; else empty).
struct BevTargets {
  int channels = bev_channels::kCount;
  std::vector<float> values;
  std::vector<float> votes;
  std::vector<float> weight;
  std::vector<float> edges;
  int objects = 0;  // targets whose centre lies inside the grid
};

BevTargets EncodeBevTargets(const std::vector<BevObject>& objects,
                            const BevImage& image,
                            const BevCoderOptions& options);

// Where a maximum's centre comes from.
enum class BevCentre { kPeak, kVotes };
template <>
struct EnumText<BevCentre> {
  static constexpr const char* kKind = "learned centre";
  static constexpr EnumEntry<BevCentre> kEntries[] = {{BevCentre::kPeak, "peak"},
                                                      {BevCentre::kVotes, "votes"}};
};

// Which classes' maxima a network with edge votes centres between the sides
// its cells place.
enum class BevEdgeClasses { kNone, kLarge, kAll };
template <>
struct EnumText<BevEdgeClasses> {
  static constexpr const char* kKind = "edge-vote classes";
  static constexpr EnumEntry<BevEdgeClasses> kEntries[] = {
      {BevEdgeClasses::kNone, "none"},
      {BevEdgeClasses::kLarge, "large"},  // tables, sideboards and sofas
      {BevEdgeClasses::kAll, "all"},
  };
};
bool UsesEdges(BevEdgeClasses classes, FurnitureClass furniture_class);

struct BevDecodeOptions {
  // Least heat of a maximum (a candidate). Low: the operating point decides
  // what becomes a detection, and average precision sweeps the weak maxima
  // too (0.1 -> 0.03: +0.006 mAP@10cm and +0.008 for tables over seven fold
  // networks of protocol E, every one at least as high; 0.01 the same).
  double min_heat = 0.03;
  int max_per_class = 16;
  // Cross-class suppression radius (m): a weaker maximum of any class this
  // near a stronger kept one is marked suppressed. 0: off (the default: it
  // cost 0.03 mAP@10cm on unseen furniture, mostly armchairs under chairs).
  double suppress_m = 0;
  // Same-class separation (m): a weaker maximum of a class whose centre lies
  // this near a stronger one of that class is dropped, not listed (two
  // pieces of one class do not stand 20 cm apart; two maxima there are one
  // object seen twice, and the weaker one can only be a false detection).
  // 0: off. Other classes are cross-class suppression's (suppress_m).
  double same_class_m = 0.2;
  // Maxima farther than this from the sensor across the floor are dropped
  // (detection's range: the network may see farther, for context).
  double max_distance_m = std::numeric_limits<double>::infinity();
  BevCentre centre = BevCentre::kVotes;
  double vote_bandwidth_m = 0.1;  // the mean shift's Gaussian kernel (m)
  double min_membership = 0.3;    // cells below this do not vote
  // A vote's weight is membership x (the class's heat at the voting cell)^p:
  // 0 trusts every member cell alike; 1 trusts cells the network thinks
  // central more (a chair's peak is precise; its outer cells' votes less so).
  double vote_heat_power = 0;
  int mean_shift_iterations = 5;
  // Edge votes (networks trained with them): the classes centred by them
  // (none by default: on protocol E the peak cell's own centre placed tables
  // better, docs/learned-voting.md); a cell's say on a side falls off as
  // exp(-distance to it / edge_near_m); the cells whose four distances put
  // the centre within edge_agree_m of the maximum's own centre are the
  // object's.
  BevEdgeClasses edge_classes = BevEdgeClasses::kNone;
  double edge_near_m = 0.15;
  double edge_agree_m = 0.3;

  // Throws InputError naming the field and the rule.
  void Check() const;
};

struct BevPeak : FurnitureBox {  // the decoded box, world frame
  FurnitureClass furniture_class = FurnitureClass::kChair;
  double heat = 0;
  double peak_x = 0, peak_y = 0;  // the peak cell's own vote (world)
  double votes = 0;               // summed weight of the votes that placed it (kVotes)
  int edge_cells = 0;             // cells whose edge votes placed it (0: not by edges)
  bool suppressed = false;
  double suppressed_by_m = 0;  // distance to the stronger maximum, when suppressed
};

// Strongest first; suppressed maxima are kept in the list, marked.
std::vector<BevPeak> DecodeBevOutput(const BevImage& image,
                                     const BevOutput& output,
                                     const BevDecodeOptions& options);

}  // namespace furn
