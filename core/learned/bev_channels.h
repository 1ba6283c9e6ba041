// The vote network's output channels, by name (issue 37). One layout that
// the box coder (targets and decoding), the loss and the network share; no
// other file computes a channel index.
//
//   heat        kBevClasses  per class, the centre heat map (a logit; BevOutput
//                            holds it through a sigmoid, 0..1)
//   offset      2            (row, col) from the cell's centre to the centre of
//                            the object the cell belongs to, in units of
//                            kOffsetUnitM (a dense vote: VoteNet's deep Hough
//                            voting on the grid)
//   log_size    2            log footprint width and depth (m) of that object
//   yaw         2            cos, sin of symmetry x (yaw - the grid's heading)
//   membership  1            a logit: the cell belongs to a target object, so
//                            its vote counts
//   edges       4            networks trained with edge votes only (after the
//                            rest): log(distance + kEdgeEpsM) from the cell's
//                            centre to the four sides of its object's
//                            footprint's bounding box in the grid (row min,
//                            row max, col min, col max; m): FCOS's distances,
//                            each side placed by the cells near it
//
//   const float heat = output.At(bev_channels::kHeat.first + k, row, col);
#pragma once

#include "core/model/furniture_class.h"

namespace furn {

inline constexpr int kBevClasses = static_cast<int>(kAllClasses.size());

// A contiguous range of channels.
struct BevSlice {
  int first = 0;
  int count = 0;
  constexpr int end() const { return first + count; }
  constexpr int operator[](int i) const { return first + i; }
};

namespace bev_channels {

inline constexpr BevSlice kHeat{0, kBevClasses};
inline constexpr BevSlice kOffset{kHeat.end(), 2};
inline constexpr BevSlice kLogSize{kOffset.end(), 2};
inline constexpr BevSlice kYaw{kLogSize.end(), 2};
inline constexpr BevSlice kMembership{kYaw.end(), 1};
inline constexpr int kCount = kMembership.end();  // without edge votes
inline constexpr BevSlice kEdges{kCount, 4};
inline constexpr int kCountWithEdges = kEdges.end();
constexpr int CountOf(bool edge_votes) { return edge_votes ? kCountWithEdges : kCount; }

// The offset channels' unit (m): votes of a large table reach 0.5 m, so the
// loss sees them in tenths of a metre rather than in cells.
inline constexpr double kOffsetUnitM = 0.1;
// The edge distances' floor inside the log (m): a cell on a side is 0 m
// from it.
inline constexpr double kEdgeEpsM = 0.05;

}  // namespace bev_channels
}  // namespace furn
