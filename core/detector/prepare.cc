// Stage 1 of detection: the scan in the world frame, segmented, its walls
// found, its occupancy grid built (SPEC §8.1).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/detector/detector_impl.h"
#include "core/util/error.h"

namespace furn {
namespace {

// The bounding box of a segment's points.
Eigen::AlignedBox3f SegmentBox(const PointCloud& cloud, const std::vector<int>& segment) {
  Eigen::AlignedBox3f box;
  for (int i : segment) box.extend(cloud.points[i]);
  return box;
}

}  // namespace

std::vector<char> FindStructure(const ViewSegments& view,
                                double max_extent,
                                float max_height,
                                std::vector<char>* segment_flags) {
  constexpr float kOnPlane = 0.04f;    // m
  constexpr float kSpanMargin = 0.1f;  // m
  const PointCloud& cloud = view.cloud;
  std::vector<char> structure(cloud.size(), 0);
  struct Plane {
    Eigen::Vector3f centre, normal, along;  // along: horizontal, in the plane
    float low, high;                        // span along `along`
  };
  std::vector<Plane> planes;
  for (const std::vector<int>& segment : view.segments) {
    const Eigen::AlignedBox3f box = SegmentBox(cloud, segment);
    if (box.sizes().maxCoeff() <= max_extent && box.max().z() <= max_height) continue;
    for (int i : segment) structure[i] = 1;
    Eigen::Vector3f centre = Eigen::Vector3f::Zero();
    for (int i : segment) centre += cloud.points[i];
    centre /= static_cast<float>(segment.size());
    Eigen::Matrix3f scatter = Eigen::Matrix3f::Zero();
    for (int i : segment) {
      const Eigen::Vector3f d = cloud.points[i] - centre;
      scatter += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver(scatter);
    const Eigen::Vector3f normal = solver.eigenvectors().col(0);
    const float thickness = std::sqrt(solver.eigenvalues()(0) / segment.size());
    if (std::abs(normal.z()) > 0.2f || thickness > kOnPlane / 2) continue;  // not a vertical plane
    Plane plane{
        centre, normal, Eigen::Vector3f(-normal.y(), normal.x(), 0).normalized(), 1e9f, -1e9f};
    for (int i : segment) {
      const float t = plane.along.dot(cloud.points[i] - centre);
      plane.low = std::min(plane.low, t);
      plane.high = std::max(plane.high, t);
    }
    planes.push_back(plane);
  }
  for (const Plane& plane : planes) {
    for (size_t i = 0; i < cloud.size(); ++i) {
      const Eigen::Vector3f d = cloud.points[i] - plane.centre;
      const float t = plane.along.dot(d);
      if (std::abs(plane.normal.dot(d)) <= kOnPlane && t >= plane.low - kSpanMargin &&
          t <= plane.high + kSpanMargin) {
        structure[i] = 1;
      }
    }
  }
  segment_flags->assign(view.segments.size(), 0);
  for (size_t s = 0; s < view.segments.size(); ++s) {
    size_t flagged = 0;
    for (int i : view.segments[s]) flagged += structure[i];
    (*segment_flags)[s] = 2 * flagged > view.segments[s].size();
  }
  return structure;
}

namespace {

// A finite point within the range (squared) of the sensor (camera frame).
bool InRange(const Eigen::Vector3f& p, float max_range2) {
  return p.allFinite() && p.squaredNorm() > 0 && p.squaredNorm() <= max_range2;
}

float SquaredRange(double max_range_m) { return static_cast<float>(max_range_m * max_range_m); }

int CountInRange(const std::vector<Eigen::Vector3f>& points, double max_range_m) {
  const float max_range2 = SquaredRange(max_range_m);
  int in_range = 0;
  for (const Eigen::Vector3f& p : points) in_range += InRange(p, max_range2);
  return in_range;
}

// The camera's pose in the floor frame: given, or found by FindFloor. False
// with the scan's status and message set when no floor is found.
bool PlaceInWorld(const DetectionInput& input, const DetectorOptions& options, PreparedScan* scan) {
  if (input.world_from_camera) {
    scan->world_from_camera = *input.world_from_camera;
    return true;
  }
  // The floor is found among all points up to 6 m (or the detection range,
  // when larger): in a real room seen level the floor within detection
  // range may be a sliver, the rest of it a little farther.
  const FloorEstimate floor =
      EstimateFloor(input.points, options.floor, std::max(kFloorSearchRangeM, options.max_range_m));
  if (!floor.found) {
    // Not the input's fault alone (the floor may be out of range or view):
    // a frame without detections, the reason in the message.
    scan->status = DetectionStatus::kNoFloor;
    scan->message =
        floor.message + "; give the camera's pose (world_from_camera) or a larger max_range_m";
    return false;
  }
  scan->world_from_camera = floor.world_from_camera;
  scan->floor_estimated = true;
  return true;
}

// An organised scan's intrinsics and size (false for unorganised scans):
// what projects a point onto its pixel.
bool KeepIntrinsics(const DetectionInput& input, PreparedScan* scan) {
  if (input.width * input.height == 0) return false;
  scan->intrinsics = IntrinsicsOfOrganisedCloud(input.points, input.width, input.height);
  if (!scan->intrinsics) return false;
  scan->width = input.width;
  scan->height = input.height;
  return true;
}

}  // namespace

void KeepDepthImage(const DetectionInput& input, double max_range_m, PreparedScan* scan) {
  if (!KeepIntrinsics(input, scan)) return;
  const float max_range2 = SquaredRange(max_range_m);
  scan->depth.assign(input.points.size(), std::numeric_limits<float>::quiet_NaN());
  for (size_t i = 0; i < input.points.size(); ++i) {
    const Eigen::Vector3f& p = input.points[i];
    if (p.allFinite() && p.z() > 0 && p.squaredNorm() <= max_range2) scan->depth[i] = p.z();
  }
}

PreparedScan Detector::Prepare(const DetectionInput& input) const {
  PreparedScan scan = PlaceScan(input);
  const bool fits = !impl_->learned || impl_->options.learned_fit;
  if (scan.status == DetectionStatus::kDetected && fits) SegmentScan(input, &scan);
  return scan;
}

PreparedScan Detector::PlaceScan(const DetectionInput& input) const {
  const Impl& impl = *impl_;
  const DetectorOptions& options = impl.options;
  PreparedScan scan;
  StageTimer timer(&scan.timings_ms);
  Require(input.width * input.height == 0 ||
              static_cast<size_t>(input.width) * input.height == input.points.size(),
          "organised cloud of " + std::to_string(input.points.size()) + " points is not " +
              std::to_string(input.width) + "x" + std::to_string(input.height));

  // World frame, range, floor.
  scan.input_points = CountInRange(input.points, options.max_range_m);
  if (scan.input_points == 0) {  // a frame of nothing in range: nothing to detect, not an error
    scan.status = DetectionStatus::kNoPointsInRange;
    char message[96];
    std::snprintf(message,
                  sizeof(message),
                  "the scan has no finite point within %g m of the sensor",
                  options.max_range_m);
    scan.message = message;
    return scan;
  }
  if (!PlaceInWorld(input, options, &scan)) return scan;
  scan.sensor = scan.world_from_camera.translation().cast<float>();
  if (impl.learned) {  // the network's grid is rasterised from the points as given
    scan.camera_points = input.points;
    // The extent fit's visibility test and each detection's share in view
    // project onto the scan's pixels (SegmentScan keeps them again, with
    // the depth image, when the fits need it).
    if (!options.learned_fit) KeepIntrinsics(input, &scan);
  }
  timer.Lap(DetectionStage::kFloor);
  return scan;
}

void OccupancyHandoff::Offer(std::vector<Eigen::Vector3f> world,
                             const Eigen::Vector3f& sensor,
                             double voxel_m) {
  world_ = std::move(world);
  sensor_ = sensor;
  voxel_m_ = voxel_m;
  offered_.store(true, std::memory_order_release);
}

bool OccupancyHandoff::BuildIfFree(StageTimings* timings) {
  if (!offered_.load(std::memory_order_acquire) || claimed_.exchange(true)) return false;
  StageTimer timer(timings);
  // Occupancy for verification, from every point in range (floor included).
  grid_.emplace(FirstPointPerVoxel(world_, voxel_m_), sensor_, voxel_m_);
  timer.Lap(DetectionStage::kOccupancy);
  return true;
}

void OccupancyHandoff::MarkPreprocessed() {
  {
    std::lock_guard<std::mutex> lock(preprocessed_mutex_);
    preprocessed_ = true;
  }
  preprocessed_changed_.notify_all();
}

void OccupancyHandoff::WaitUntilPreprocessed() {
  std::unique_lock<std::mutex> lock(preprocessed_mutex_);
  preprocessed_changed_.wait(lock, [&] { return preprocessed_; });
}

void Detector::SegmentScan(const DetectionInput& input, PreparedScan* scan) const {
  OccupancyHandoff handoff;
  SegmentScan(input, scan, &handoff);
  scan->occupancy = handoff.Take();
}

void Detector::SegmentScan(const DetectionInput& input,
                           PreparedScan* scan_out,
                           OccupancyHandoff* handoff) const {
  const Impl& impl = *impl_;
  const DetectorOptions& options = impl.options;
  PreparedScan& scan = *scan_out;
  // On every way out, exceptions included: the other branch may wait for it.
  struct MarkOnExit {
    OccupancyHandoff* handoff;
    ~MarkOnExit() { handoff->MarkPreprocessed(); }
  } mark_on_exit{handoff};
  const auto start = std::chrono::steady_clock::now();
  const Eigen::Matrix3f rotation = scan.world_from_camera.linear().cast<float>();
  const Eigen::Vector3f translation = scan.world_from_camera.translation().cast<float>();
  const float max_range2 = SquaredRange(options.max_range_m);
  std::vector<Eigen::Vector3f> world, above_floor;
  world.reserve(scan.input_points);
  above_floor.reserve(scan.input_points);
  for (const Eigen::Vector3f& p : input.points) {
    if (!InRange(p, max_range2)) continue;
    world.push_back(rotation * p + translation);
    if (world.back().z() >= options.floor_band_m) above_floor.push_back(world.back());
  }
  handoff->Offer(std::move(world), scan.sensor, options.occupancy_voxel_m);
  const double to_world_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();

  // Segments and features, exactly as in training (learned voting's fits
  // use no features: no codebook words).
  SegmentTimings segment_timings;
  scan.view = SegmentView(
      above_floor, scan.sensor, impl.model.options, &segment_timings, !impl.learned, [handoff] {
        handoff->MarkPreprocessed();
      });
  const auto segmented = std::chrono::steady_clock::now();
  scan.timings_ms.Add(DetectionStage::kPreprocess, to_world_ms + segment_timings.preprocess_ms);
  scan.timings_ms.Add(DetectionStage::kSegment, segment_timings.segment_ms);
  const size_t segment_entry = scan.timings_ms.stages.size() - 1;  // walls, depth image to come
  if (!impl.learned) scan.timings_ms.Add(DetectionStage::kFeatures, segment_timings.features_ms);
  scan.segment_of_point.assign(scan.view.cloud.size(), -1);
  for (size_t segment = 0; segment < scan.view.segments.size(); ++segment) {
    for (int point : scan.view.segments[segment])
      scan.segment_of_point[point] = static_cast<int>(segment);
  }

  // Walls: they neither vote nor count against a fit (a sideboard stands
  // against one).
  scan.structure = FindStructure(
      scan.view, options.max_segment_extent_m, impl.structure_height_m, &scan.structure_segment);
  if (handoff->ClaimDepthImage()) KeepDepthImage(input, options.max_range_m, &scan);
  scan.timings_ms.stages[segment_entry].ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - segmented)
          .count();
  handoff->BuildIfFree(&scan.timings_ms);
}

}  // namespace furn
