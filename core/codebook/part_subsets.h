// Part subsets for CAD model ranking (Usenko et al. Sec. IV-E; SPEC.md §7.7):
// from each view, subsets of 1 to 3 adjacent segments (adjacent: points of the
// two lie within the adjacency distance), each described by PCL's Viewpoint
// Feature Histogram and labelled with its CAD model and class; a nearest
// neighbour index (L2 in principal components) ranks the models for a query.
//
//   std::vector<std::vector<int>> subsets = PartSubsets(view, PartSubsetOptions{});
//   VfhDescriptor d = ComputeVfh(view.cloud, points_of(subset), sensor_origin);
//   PartSubsetIndex index(descriptors);
//   std::vector<int> nearest = index.Nearest(d, 5);
#pragma once

#include <Eigen/Core>
#include <array>
#include <functional>
#include <memory>
#include <vector>

#include "core/codebook/view_segments.h"
#include "core/geometry/point_cloud.h"

namespace furn {

struct PartSubsetOptions {
  int min_subset_size = 1;        // 1..max_subset_size segments (2 leaves out lone generic parts)
  int max_subset_size = 3;        // 1..3 segments
  int max_subsets_per_view = 64;  // singletons first, then pairs, then triples (>= 1)
  double adjacency_m = 0.05;      // segments touch within this distance (m, > 0)
  // VFH with its shape-distribution part filled (PCL's size component: the
  // points' distances from the centroid, in absolute centimetres), which
  // the paper's VFH leaves empty. It tells parts of one shape at different
  // sizes apart (the paper's 1600x800 and 2000x1000 tables): protocol C on
  // the paper's 8 models goes from 77.0 % / 85.9 % to 81.8 % / 88.1 %.
  bool vfh_size_component = false;

  void Check() const;
};

using VfhDescriptor = std::array<float, 308>;

// Segment index lists of the view's subsets, in a fixed order.
std::vector<std::vector<int>> PartSubsets(const ViewSegments& view,
                                          const PartSubsetOptions& options);

// VFH of the points (indices into `cloud`) seen from `viewpoint`; with
// `size_component`, its distance histogram filled in absolute centimetres.
VfhDescriptor ComputeVfh(const PointCloud& cloud,
                         const std::vector<int>& points,
                         const Eigen::Vector3f& viewpoint,
                         bool size_component = false);

// Nearest neighbours (L2) over a set of descriptors, searched exactly in the
// space of their first `dimensions` principal components (VFH bins are
// strongly correlated: 48 components keep the ranking and make a query over
// tens of thousands of descriptors take well under a millisecond). The
// components come from a fixed subsample, so the index is deterministic.
class PartSubsetIndex {
 public:
  // What the index searches: stored in model files, so a detector loads it
  // instead of computing it.
  struct State {
    Eigen::RowVectorXf mean;    // 1 x 308
    Eigen::MatrixXf basis;      // 308 x d
    Eigen::MatrixXf projected;  // n x d
  };
  explicit PartSubsetIndex(const std::vector<VfhDescriptor>& descriptors, int dimensions = 48);
  // The same over `count` descriptors given by an accessor (no copy of them).
  PartSubsetIndex(size_t count,
                  const std::function<const VfhDescriptor&(size_t)>& descriptor,
                  int dimensions = 48);
  // Throws InputError for an inconsistent state (sizes that do not match).
  explicit PartSubsetIndex(State state);
  ~PartSubsetIndex();
  const State& state() const;
  size_t size() const;
  // Indices of the k nearest descriptors, nearest first (ties by index).
  std::vector<int> Nearest(const VfhDescriptor& query, int k) const;
  // The same for many queries at once, much faster than one by one (the
  // library is read once for all of them; both cores); one list per query.
  std::vector<std::vector<int>> NearestMany(const std::vector<VfhDescriptor>& queries, int k) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace furn
