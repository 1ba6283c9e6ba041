#include "core/codebook/segment_view.h"

#include <chrono>

#include "core/util/parallel.h"

namespace furn {

std::vector<int> PointsOfSegments(const ViewSegments& view, const std::vector<int>& segments) {
  std::vector<int> points;
  for (int s : segments)
    points.insert(points.end(), view.segments[s].begin(), view.segments[s].end());
  return points;
}

Eigen::Matrix2f ViewAlignedFromWorld(const Eigen::Vector3f& sensor,
                                     const Eigen::Vector3f& centroid) {
  Eigen::Vector2f x = (centroid - sensor).head<2>();
  if (x.norm() < 1e-6f) x = Eigen::Vector2f::UnitX();
  x.normalize();
  Eigen::Matrix2f aligned_from_world;
  aligned_from_world << x.x(), x.y(), -x.y(), x.x();
  return aligned_from_world;
}

ViewSegments SegmentView(const std::vector<Eigen::Vector3f>& points,
                         const Eigen::Vector3f& sensor_origin,
                         const TrainerOptions& options,
                         SegmentTimings* timings,
                         bool features,
                         const std::function<void()>& preprocessed) {
  using Clock = std::chrono::steady_clock;
  auto lap = [last = Clock::now()](double* ms) mutable {
    const auto now = Clock::now();
    if (ms != nullptr) *ms = std::chrono::duration<double, std::milli>(now - last).count();
    last = now;
  };
  ViewSegments view;
  view.cloud = Preprocess(points, sensor_origin, options.preprocess);
  lap(timings ? &timings->preprocess_ms : nullptr);
  if (preprocessed) preprocessed();
  if (view.cloud.size() == 0) return view;
  view.segments = GrowRegions(view.cloud, options.region_growing);
  lap(timings ? &timings->segment_ms : nullptr);
  if (features) view.features.resize(view.segments.size());
  view.centroids.resize(view.segments.size());
  ParallelFor(0, static_cast<int>(view.segments.size()), [&](int s) {
    const std::vector<int>& segment = view.segments[s];
    if (features) view.features[s] = ComputeSgf(view.cloud, segment, options.sgf);
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
    for (int i : segment) centroid += view.cloud.points[i];
    view.centroids[s] = centroid / static_cast<float>(segment.size());
  });
  lap(timings ? &timings->features_ms : nullptr);
  return view;
}

}  // namespace furn
