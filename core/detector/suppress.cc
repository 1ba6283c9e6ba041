// The last stage of detection: best score first, a detection is dropped
// when better ones already explain its points or its footprint overlaps one
// of theirs.
#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "core/detector/detector_impl.h"

namespace furn {
namespace {

// The footprint of `shape` posed at `pose`, as an OpenCV rotated rectangle.
cv::RotatedRect Footprint(const ModelShape& shape, const PlanarPose& pose) {
  const Eigen::Vector3f centre = pose.Apply((shape.low + shape.high) / 2);
  const Eigen::Vector3f size = shape.high - shape.low;
  return cv::RotatedRect(cv::Point2f(centre.x(), centre.y()),
                         cv::Size2f(size.x(), size.y()),
                         static_cast<float>(pose.yaw * 180 / M_PI));
}

// Intersection area of two footprints over the smaller one's area.
double FootprintOverlap(const cv::RotatedRect& a, const cv::RotatedRect& b) {
  std::vector<cv::Point2f> region;
  if (cv::rotatedRectangleIntersection(a, b, region) == cv::INTERSECT_NONE || region.size() < 3)
    return 0;
  std::vector<cv::Point2f> hull;
  cv::convexHull(region, hull);
  const double smaller = std::min(a.size.area(), b.size.area());
  return smaller > 0 ? cv::contourArea(hull) / smaller : 0;
}

}  // namespace

std::vector<int> Detector::Suppress(const PreparedScan& scan,
                                    const std::vector<FittedHypothesis>& fits,
                                    std::vector<DetectionDebug::Hypothesis>* hypotheses) const {
  const DetectorOptions& options = impl_->options;
  const TrainedModel& model = impl_->model;
  // Best score first: a detection is dropped when kept ones already explain
  // more than max_shared_support of the points it explains, or when its
  // footprint overlaps a kept one's by more than max_footprint_overlap (of
  // the smaller footprint).
  std::vector<int> order;
  for (size_t h = 0; h < fits.size(); ++h) {
    if (fits[h].detection) order.push_back(static_cast<int>(h));
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return fits[a].detection->score > fits[b].detection->score;
  });
  std::vector<int> kept;
  std::vector<char> explained(scan.view.cloud.size(), 0);
  for (int h : order) {
    const Detection& d = *fits[h].detection;
    const std::vector<int>& support = fits[h].support;
    size_t shared = 0;
    for (int i : support) shared += explained[i];
    const double shared_fraction =
        support.empty() ? 1.0 : static_cast<double>(shared) / support.size();
    const cv::RotatedRect footprint =
        Footprint(model.model_shapes[d.model_index], PlanarPose{d.x, d.y, d.yaw});
    double overlap = 0;
    for (int k : kept) {
      const Detection& other = *fits[k].detection;
      overlap = std::max(overlap,
                         FootprintOverlap(footprint,
                                          Footprint(model.model_shapes[other.model_index],
                                                    PlanarPose{other.x, other.y, other.yaw})));
    }
    if (shared_fraction > options.max_shared_support || overlap > options.max_footprint_overlap) {
      (*hypotheses)[h].outcome = HypothesisOutcome::kSuppressed;
      (*hypotheses)[h].outcome_values[0] = shared_fraction;
      (*hypotheses)[h].outcome_values[1] = overlap;
      continue;
    }
    for (int i : support) explained[i] = 1;
    kept.push_back(h);
  }
  return kept;
}

}  // namespace furn
