#include "core/geometry/floor.h"

#include <immintrin.h>
#include <pcl/console/print.h>
#include <pcl/features/normal_3d.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>
#include <pcl/search/kdtree.h>

#include <cmath>
#include <cstdio>
#include <optional>

#include "core/geometry/pcl_conversion.h"
#include "core/util/error.h"
#include "core/util/parallel.h"

namespace furn {

void FloorOptions::Check() const {
  Require(distance_m >= 0.002 && distance_m <= 0.2,
          "floor distance " + std::to_string(distance_m) + " m must be in 0.002..0.2");
  Require(iterations >= 10 && iterations <= 100000,
          "floor RANSAC iterations " + std::to_string(iterations) + " must be in 10..100000");
  Require(sample_points >= 1000 && sample_points <= 1000000,
          "floor sample points " + std::to_string(sample_points) + " must be in 1000..1000000");
  Require(max_tilt_deg >= 1 && max_tilt_deg <= 89, "floor max tilt must be in 1..89 degrees");
  Require(min_fraction > 0 && min_fraction < 1, "floor min fraction must be in (0, 1)");
  Require(min_camera_height_m >= 0 && max_camera_height_m > min_camera_height_m,
          "floor camera heights must be 0 <= min < max (m), not " +
              std::to_string(min_camera_height_m) + " and " + std::to_string(max_camera_height_m));
}

Eigen::Isometry3d WorldOfFloor(const Eigen::Vector3d& normal, double offset) {
  const Eigen::Vector3d z = normal;
  Eigen::Vector3d x = Eigen::Vector3d::UnitZ() - z * z.z();
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX() - z * z.x();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_camera_rotation;
  world_from_camera_rotation.row(0) = x.transpose();
  world_from_camera_rotation.row(1) = y.transpose();
  world_from_camera_rotation.row(2) = z.transpose();
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  world_from_camera.linear() = world_from_camera_rotation;
  world_from_camera.translation() = Eigen::Vector3d(0, 0, offset);
  return world_from_camera;
}

namespace {

// The largest float f with f < threshold: a float d has d < threshold
// exactly when d <= f.
float LargestFloatBelow(double threshold) {
  float f = static_cast<float>(threshold);
  while (static_cast<double>(f) >= threshold) f = std::nextafter(f, -INFINITY);
  return f;
}

}  // namespace

namespace {

// Four points at a time (SSE2: every x86-64 CPU).
size_t CountNearPlaneSse2(const float* x,
                          const float* y,
                          const float* z,
                          size_t n,
                          const Eigen::Vector4f& coefficients,
                          float limit) {
  const __m128 c0 = _mm_set1_ps(coefficients[0]), c1 = _mm_set1_ps(coefficients[1]);
  const __m128 c2 = _mm_set1_ps(coefficients[2]), c3 = _mm_set1_ps(coefficients[3]);
  const __m128 limit4 = _mm_set1_ps(limit);
  const __m128 sign = _mm_set1_ps(-0.0f);
  size_t count = 0;
  size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m128 xz =
        _mm_add_ps(_mm_mul_ps(c0, _mm_loadu_ps(&x[i])), _mm_mul_ps(c2, _mm_loadu_ps(&z[i])));
    const __m128 y1 = _mm_add_ps(_mm_mul_ps(c1, _mm_loadu_ps(&y[i])), c3);
    const __m128 distance = _mm_andnot_ps(sign, _mm_add_ps(xz, y1));
    const int within = _mm_movemask_ps(_mm_cmple_ps(distance, limit4));
    count += static_cast<size_t>(__builtin_popcount(static_cast<unsigned>(within)));
  }
  for (; i < n; ++i) {
    const float xz = coefficients[0] * x[i] + coefficients[2] * z[i];
    const float y1 = coefficients[1] * y[i] + coefficients[3];
    count += std::abs(xz + y1) <= limit;
  }
  return count;
}

// Eight points at a time, the same products and sums as the SSE2 path (AVX2
// without FMA: nothing is fused, so every count is the same); the rest by it.
__attribute__((target("avx2"))) size_t CountNearPlaneAvx2(const float* x,
                                                          const float* y,
                                                          const float* z,
                                                          size_t n,
                                                          const Eigen::Vector4f& coefficients,
                                                          float limit) {
  const __m256 c0 = _mm256_set1_ps(coefficients[0]), c1 = _mm256_set1_ps(coefficients[1]);
  const __m256 c2 = _mm256_set1_ps(coefficients[2]), c3 = _mm256_set1_ps(coefficients[3]);
  const __m256 limit8 = _mm256_set1_ps(limit);
  const __m256 sign = _mm256_set1_ps(-0.0f);
  size_t count = 0;
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 xz = _mm256_add_ps(_mm256_mul_ps(c0, _mm256_loadu_ps(&x[i])),
                                    _mm256_mul_ps(c2, _mm256_loadu_ps(&z[i])));
    const __m256 y1 = _mm256_add_ps(_mm256_mul_ps(c1, _mm256_loadu_ps(&y[i])), c3);
    const __m256 distance = _mm256_andnot_ps(sign, _mm256_add_ps(xz, y1));
    const int within = _mm256_movemask_ps(_mm256_cmp_ps(distance, limit8, _CMP_LE_OQ));
    count += static_cast<size_t>(__builtin_popcount(static_cast<unsigned>(within)));
  }
  return count + CountNearPlaneSse2(x + i, y + i, z + i, n - i, coefficients, limit);
}

}  // namespace

size_t CountNearPlane(const std::vector<float>& x,
                      const std::vector<float>& y,
                      const std::vector<float>& z,
                      const Eigen::Vector4f& coefficients,
                      double threshold,
                      SimdPath path) {
  Require(x.size() == y.size() && x.size() == z.size(), "CountNearPlane: arrays differ in size");
  static const bool kHasAvx2 = __builtin_cpu_supports("avx2");
  const float limit = LargestFloatBelow(threshold);
  if (path == SimdPath::kAvx2) Require(kHasAvx2, "CountNearPlane: this CPU has no AVX2");
  if (path == SimdPath::kAvx2 || (path == SimdPath::kBest && kHasAvx2))
    return CountNearPlaneAvx2(x.data(), y.data(), z.data(), x.size(), coefficients, limit);
  return CountNearPlaneSse2(x.data(), y.data(), z.data(), x.size(), coefficients, limit);
}

namespace {

// PCL's plane perpendicular to an axis, with its inlier count (RANSAC's
// inner loop: every iteration counts the points within the threshold)
// by CountNearPlane over a copy of the points in three arrays.
class CountedPerpendicularPlane
    : public pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ> {
 public:
  CountedPerpendicularPlane(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud,
                            const pcl::Indices& indices)
      : pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>(cloud, indices) {
    const size_t n = indices.size();
    x_.resize(n);
    y_.resize(n);
    z_.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const pcl::PointXYZ& p = (*cloud)[indices[i]];
      x_[i] = p.x;
      y_[i] = p.y;
      z_[i] = p.z;
    }
  }

  std::size_t countWithinDistance(const Eigen::VectorXf& coefficients,
                                  const double threshold) const override {
    if (!isModelValid(coefficients)) return 0;
    return CountNearPlane(x_, y_, z_, coefficients.head<4>(), threshold);
  }

 private:
  std::vector<float> x_, y_, z_;
};

// A plane and its inliers, as PCL's SACSegmentation finds it (RANSAC with
// the fixed seed, then the coefficients refined on the inliers and the
// inliers taken again), with the counted model above.
struct RansacPlane {
  Eigen::VectorXf coefficients;
  pcl::Indices inliers;
};
std::optional<RansacPlane> FindRansacPlane(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud,
                                           const pcl::Indices& indices,
                                           const FloorOptions& options) {
  auto model = std::make_shared<CountedPerpendicularPlane>(cloud, indices);
  model->setAxis(Eigen::Vector3f(0, -1, 0));  // camera up
  model->setEpsAngle(options.max_tilt_deg * M_PI / 180);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, options.distance_m);
  ransac.setMaxIterations(options.iterations);
  if (!ransac.computeModel(0)) return std::nullopt;
  RansacPlane plane;
  pcl::Indices inliers;
  ransac.getInliers(inliers);
  Eigen::VectorXf coefficients(4);
  ransac.getModelCoefficients(coefficients);
  model->optimizeModelCoefficients(inliers, coefficients, plane.coefficients);
  model->selectWithinDistance(plane.coefficients, options.distance_m, plane.inliers);
  return plane;
}

// Planes RANSAC draws, one after another with the last one's points removed.
constexpr int kPlaneAttempts = 6;

// FacingUpPoints on a PCL cloud of finite points.
std::vector<bool> FacingUpAmong(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud,
                                double max_tilt_deg) {
  constexpr int kNeighbours = 12;           // NormalEstimation's setKSearch
  pcl::search::KdTree<pcl::PointXYZ> tree;  // sorted results, as NormalEstimation's
  tree.setInputCloud(cloud);
  const double cos_tilt = std::cos(max_tilt_deg * M_PI / 180);  // compared as double, as before
  const int count = static_cast<int>(cloud->size());
  std::vector<char> facing_up(cloud->size(), 0);  // not vector<bool>: threads write neighbours
  constexpr int kChunk = 256;
  ParallelFor(0, (count + kChunk - 1) / kChunk, [&](int chunk) {
    pcl::Indices neighbours(kNeighbours);
    std::vector<float> squared_distances(kNeighbours);
    EIGEN_ALIGN16 Eigen::Matrix3f covariance;
    Eigen::Vector4f centroid;
    for (int i = chunk * kChunk; i < std::min(count, (chunk + 1) * kChunk); ++i) {
      // NormalEstimation::computeFeature and computePointNormal, step by
      // step (the sign its viewpoint flip chooses does not matter here).
      if (tree.nearestKSearch(*cloud, i, kNeighbours, neighbours, squared_distances) == 0 ||
          neighbours.size() < 3 ||
          pcl::computeMeanAndCovarianceMatrix(*cloud, neighbours, covariance, centroid) == 0)
        continue;
      float nx, ny, nz, curvature;
      pcl::solvePlaneParameters(covariance, nx, ny, nz, curvature);
      facing_up[i] = std::isfinite(ny) && std::abs(ny) >= cos_tilt;
    }
  });
  return std::vector<bool>(facing_up.begin(), facing_up.end());
}

// Planes found largest first by RANSAC among a fixed subsample; walls and
// table tops are skipped by the axis test or by lying above other points.
class FloorSearch {
 public:
  FloorSearch(const std::vector<Eigen::Vector3f>& sample, const FloorOptions& options)
      : sample_(sample), options_(options), cloud_(ToPclPoints(sample)) {
    // PCL prints its own complaints when a plane is not found; ours is the
    // one line the user sees.
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  }

  // Planes among the `candidates` RANSAC may draw from, largest first; the
  // first that can be the floor. (Taking the lowest of those that can was
  // measured worse on NYU's real frames: planes of filled depth below the
  // floor; docs/real-scans.md.)
  std::optional<Eigen::Isometry3d> Among(const std::vector<bool>& candidates) {
    std::vector<bool> removed(sample_.size(), false);
    for (int attempt = 0; attempt < kPlaneAttempts; ++attempt) {
      pcl::Indices indices;
      for (size_t i = 0; i < sample_.size(); ++i) {
        if (!removed[i] && candidates[i]) indices.push_back(static_cast<int>(i));
      }
      if (indices.size() < 3) break;
      const std::optional<RansacPlane> found = FindRansacPlane(cloud_, indices, options_);
      if (!found || found->coefficients.size() != 4) break;
      const Eigen::VectorXf& coefficients = found->coefficients;
      Eigen::Vector3d normal(coefficients[0], coefficients[1], coefficients[2]);
      double offset = coefficients[3];
      const double length = normal.norm();
      normal /= length;
      offset /= length;
      if (offset < 0) {  // orient towards the camera: n.c + d > 0 at c = 0
        normal = -normal;
        offset = -offset;
      }
      // A ceiling (or a plane at no mounting height) is set aside however
      // large it is: the floor may be a sliver below a large ceiling.
      if (IsBelowCamera(normal, offset)) {
        const PlaneSupport plane = SupportOf(normal, offset);
        // The floor holds a share of what lies below the camera's height.
        if (plane.support < options_.min_fraction * plane.lower) break;
        if (plane.below < 0.02 * sample_.size()) return WorldOfFloor(normal, offset);
      }
      for (int i : found->inliers) removed[i] = true;
    }
    return std::nullopt;
  }

  // A plane's support among all sample points (not only the candidates),
  // the points below it (a floor has almost none) and those lower than the
  // camera (the floor's share is of these).
  struct PlaneSupport {
    size_t support = 0, below = 0, lower = 0;
  };
  PlaneSupport SupportOf(const Eigen::Vector3d& normal, double offset) const {
    PlaneSupport plane;
    for (const Eigen::Vector3f& p : sample_) {
      const double distance = normal.dot(p.cast<double>()) + offset;
      plane.support += std::abs(distance) <= options_.distance_m;
      plane.below += distance < -3 * options_.distance_m;
      plane.lower += distance < offset;
    }
    return plane;
  }

  // A floor lies below the camera: its normal towards the camera points up
  // (against the optical y) within the tilt, unlike a ceiling's, and the
  // camera's height above it is a mounting height.
  bool IsBelowCamera(const Eigen::Vector3d& normal, double offset) const {
    const double cos_tilt = std::cos(options_.max_tilt_deg * M_PI / 180);
    return -normal.y() >= cos_tilt && offset >= options_.min_camera_height_m &&
           offset <= options_.max_camera_height_m;
  }

  // The sample points whose surface faces up (within the tilt).
  std::vector<bool> FacingUp() const { return FacingUpAmong(cloud_, options_.max_tilt_deg); }

 private:
  const std::vector<Eigen::Vector3f>& sample_;
  const FloorOptions& options_;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
};

// The floor search on the points that pass `keep`: RANSAC on a fixed
// subsample (every k-th of them, about options.sample_points) keeps it fast
// and deterministic. The subsample is taken in one pass, without copying
// the kept points first.
template <class Keep>
FloorEstimate SearchFloorAmong(const std::vector<Eigen::Vector3f>& points_in_camera,
                               const FloorOptions& options,
                               Keep&& keep) {
  options.Check();
  size_t kept = 0;
  for (const Eigen::Vector3f& p : points_in_camera) kept += keep(p);
  FloorEstimate estimate;
  if (kept < 100) {
    estimate.message = "floor: " + std::to_string(kept) + " finite points; at least 100 are needed";
    return estimate;
  }
  const size_t stride = std::max<size_t>(1, kept / static_cast<size_t>(options.sample_points));
  std::vector<Eigen::Vector3f> sample;
  sample.reserve(kept / stride + 1);
  size_t k = 0;
  for (const Eigen::Vector3f& p : points_in_camera) {
    if (!keep(p)) continue;
    if (k++ % stride == 0) sample.push_back(p);
  }
  FloorSearch search(sample, options);
  std::optional<Eigen::Isometry3d> floor = search.Among(std::vector<bool>(sample.size(), true));
  // A small floor among large walls (a real room seen level) is rarely drawn
  // by RANSAC; again among the points whose surface faces up.
  if (!floor) floor = search.Among(search.FacingUp());
  if (floor) {
    estimate.found = true;
    estimate.world_from_camera = *floor;
    return estimate;
  }
  char why[200];
  std::snprintf(why,
                sizeof why,
                "no floor found: no plane below the camera within %g degrees of its up direction "
                "holds %g%% of the points lower than the camera with nothing below it",
                options.max_tilt_deg,
                100 * options.min_fraction);
  estimate.message = why;
  return estimate;
}

}  // namespace

FloorEstimate SearchFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                          const FloorOptions& options) {
  return SearchFloorAmong(
      points_in_camera, options, [](const Eigen::Vector3f& p) { return p.allFinite(); });
}

Eigen::Isometry3d FindFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                            const FloorOptions& options) {
  const FloorEstimate estimate = SearchFloor(points_in_camera, options);
  if (!estimate.found) throw InputError(estimate.message);
  return estimate.world_from_camera;
}

std::vector<bool> FacingUpPoints(const std::vector<Eigen::Vector3f>& points, double max_tilt_deg) {
  for (const Eigen::Vector3f& p : points)
    Require(p.allFinite(), "FacingUpPoints: every point must be finite");
  return FacingUpAmong(ToPclPoints(points), max_tilt_deg);
}

FloorEstimate EstimateFloor(const std::vector<Eigen::Vector3f>& points_in_camera,
                            const FloorOptions& options,
                            double search_range_m) {
  const float range2 = static_cast<float>(search_range_m * search_range_m);
  return SearchFloorAmong(points_in_camera, options, [range2](const Eigen::Vector3f& p) {
    return p.allFinite() && p.squaredNorm() > 0 && p.squaredNorm() <= range2;
  });
}

}  // namespace furn
