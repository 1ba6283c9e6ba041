// One view's segments as training and detection both make them: the shared
// preprocessing, region growing and SGFs (SPEC §5).
#pragma once

#include <functional>

#include <Eigen/Core>
#include <vector>

#include "core/codebook/trainer_options.h"
#include "core/codebook/view_segments.h"

namespace furn {

// Segments and normalisation-free SGFs of one view (shared with detection).
struct SegmentTimings {
  double preprocess_ms = 0, segment_ms = 0, features_ms = 0;
};
// With `features` false the segments' SGFs are left empty (what learned
// voting's fits need: segments and centroids, no codebook words).
// `preprocessed`, when given, is called once the preprocessing (the MLS fit,
// on every core) is over, before region growing (serial).
ViewSegments SegmentView(const std::vector<Eigen::Vector3f>& points,
                         const Eigen::Vector3f& sensor_origin,
                         const TrainerOptions& options,
                         SegmentTimings* timings = nullptr,
                         bool features = true,
                         const std::function<void()>& preprocessed = {});

// The cloud indices of the points of some of a view's segments.
std::vector<int> PointsOfSegments(const ViewSegments& view, const std::vector<int>& segments);

// The horizontal, view-aligned frame of a segment seen from `sensor`: x along
// the horizontal sensor-to-segment direction, y to its left.
Eigen::Matrix2f ViewAlignedFromWorld(const Eigen::Vector3f& sensor,
                                     const Eigen::Vector3f& centroid);

}  // namespace furn
