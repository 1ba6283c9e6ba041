// 3-DOF pose fitting of a model shape to scene points (SPEC.md §8.6):
// furniture stands on the floor, so a pose is (x, y, yaw). RANSAC draws a
// scene point s and a model point m at the same height, takes the yaw from
// the difference of their normals' azimuths (uniform over [0, 2 pi) when a
// normal is near vertical), sets t = s - R m (SPEC §14: never s - m), and
// scores the pose by the scene points it covers. Half the draws instead take
// two scene points at one height and two model points as far apart as they
// are, the yaw from the directions between them: table legs and edges fix
// the pose that way whatever their normals say. The hint (the Hough
// maximum) at 24 yaws joins the draws, for shapes whose normals say little
// about their yaw (tables); the best few poses are refined by point-to-point
// ICP restricted to (x, y, yaw).
//
//   ModelFitter fitter(model.model_shapes[k], FitOptions{});
//   PoseFit fit = fitter.Fit(scene_points, scene_normals, hint_xy, seed);
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/geometry/model_shape.h"
#include "core/util/angles.h"

namespace furn {

struct PlanarPose {
  double x = 0, y = 0, yaw = 0;  // world_from_model: rotation about z, then translation

  Eigen::Vector3f Apply(const Eigen::Vector3f& model_point) const;
  Eigen::Vector3f Inverse(const Eigen::Vector3f& world_point) const;  // world -> model
};

// A PlanarPose with its sine and cosine computed once, for loops over points.
class PlanarTransform {
 public:
  explicit PlanarTransform(const PlanarPose& pose);
  Eigen::Vector3f Apply(const Eigen::Vector3f& m) const {
    return Eigen::Vector3f(c_ * m.x() - s_ * m.y() + x_, s_ * m.x() + c_ * m.y() + y_, m.z());
  }
  Eigen::Vector3f Inverse(const Eigen::Vector3f& p) const {
    const float dx = p.x() - x_, dy = p.y() - y_;
    return Eigen::Vector3f(c_ * dx + s_ * dy, -s_ * dx + c_ * dy, p.z());
  }

 private:
  float c_, s_, x_, y_;
};

// The pose that rotates `model` by `yaw` and puts it on `scene` (t = s - R m).
PlanarPose PoseFromPair(const Eigen::Vector3f& scene, const Eigen::Vector3f& model, double yaw);

// RANSAC draws a fit may make: 33 times the default (a fit's time grows
// with them; an options file from someone else could ask for days).
inline constexpr int kMaxFitIterations = 20000;

struct FitOptions {
  int iterations = 600;              // RANSAC draws (1..kMaxFitIterations)
  double height_tolerance_m = 0.01;  // |s.z - m.z| of a drawn pair (m, > 0)
  double inlier_m = 0.03;            // a scene point is covered within this of the model (m, > 0)
  double max_offset_m = 0.5;         // poses whose origin is farther from the hint are skipped
  int refine_iterations = 6;         // ICP iterations after RANSAC (0..100)
  double above_m = 0.4;  // the box whose points a fit must explain reaches this far above it

  void Check() const;
};

struct PoseFit {
  PlanarPose pose;
  int covered = 0;  // scene points within inlier_m of the posed model
  int inside = 0;   // scene points inside its bounding box grown by inlier_m (and above_m up)
  int scene_points = 0;

  // Of the scene points inside the posed model's box, the share it explains.
  double Explained() const { return inside > 0 ? static_cast<double>(covered) / inside : 0; }
  bool found = false;  // false when no draw gave a pose within max_offset_m
};

class ModelFitter {
 public:
  ModelFitter(const ModelShape& shape, const FitOptions& options);
  ~ModelFitter();
  ModelFitter(ModelFitter&&) noexcept;

  PoseFit Fit(const std::vector<Eigen::Vector3f>& scene_points,
              const std::vector<Eigen::Vector3f>& scene_normals,
              const Eigen::Vector2f& hint,
              uint64_t seed) const;

  // ICP over (x, y, yaw) from `start`, stopping when coverage would drop.
  PoseFit Refine(const std::vector<Eigen::Vector3f>& scene_points, const PlanarPose& start) const;

  // Scene points within inlier_m of the model posed at `pose`, and (when
  // `inside` is given) those inside its bounding box grown by inlier_m.
  int Covered(const std::vector<Eigen::Vector3f>& scene_points,
              const PlanarPose& pose,
              int* inside = nullptr) const;

  // Covered(), or -1 as soon as it is clear the count cannot reach `needed`.
  int CoveredAtLeast(const std::vector<Eigen::Vector3f>& scene_points,
                     const PlanarPose& pose,
                     int needed) const;

  // Indices of the scene points within inlier_m of the model posed at `pose`.
  std::vector<int> CoveredIndices(const std::vector<Eigen::Vector3f>& scene_points,
                                  const PlanarPose& pose) const;

  const ModelShape& shape() const { return *shape_; }

 private:
  struct Impl;
  const Impl& Built() const;
  void Build() const;
  const ModelShape* shape_;
  FitOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace furn
