#include "workbench/api/furnidet.h"

#include <mutex>

#include "core/detector/detection_box.h"
#include "core/detector/detector.h"
#include "core/util/data_dir.h"
#include "core/util/error.h"
#include "renderers/camera.h"
#include "renderers/depth_frame.h"
#include "workbench/formats/scan_file.h"  // BackProject
#include "workbench/pipelines/evaluate.h"

namespace furnidet {

std::string Version() { return FURN_VERSION; }

std::string DataDir() { return furn::DefaultDataDir(); }

struct Detector::Impl {
  explicit Impl(const std::string& path) : detector(furn::LoadTrainedModel(path), {}) {}

  std::vector<Box> Run(const furn::DetectionInput& input) {
    const furn::DetectionResult result = detector.Detect(input);
    {
      std::lock_guard<std::mutex> lock(mutex);
      last_pose = result.world_from_camera;
    }
    if (result.status != furn::DetectionStatus::kDetected &&
        result.status != furn::DetectionStatus::kNoPointsInRange)
      throw furn::InputError(result.message);
    std::vector<Box> boxes;
    for (const furn::Detection& d : result.detections) {
      const furn::OrientedBox box = furn::DetectionBoxInWorld(d, detector.model());
      boxes.push_back({furn::ClassName(d.furniture_class),
                       d.score,
                       {box.centre.x(), box.centre.y(), box.centre.z()},
                       {box.size.x(), box.size.y(), box.size.z()},
                       box.yaw,
                       d.model_index >= 0 ? d.model_name : std::string()});
    }
    return boxes;
  }

  furn::Detector detector;
  std::mutex mutex;
  Eigen::Isometry3d last_pose = Eigen::Isometry3d::Identity();
};

namespace {

Eigen::Isometry3d IsometryOf(const Pose& rows) {
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = rows[4 * r + c];
  }
  furn::Require(m.allFinite() && m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 1e-9),
                "world_from_camera must be finite with a last row 0 0 0 1");
  const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
  furn::Require((rotation.transpose() * rotation).isApprox(Eigen::Matrix3d::Identity(), 1e-6) &&
                    rotation.determinant() > 0,
                "world_from_camera's upper left 3x3 must be a rotation");
  Eigen::Isometry3d pose;
  pose.matrix() = m;
  return pose;
}

}  // namespace

Detector::Detector(const std::string& model_path) : impl_(std::make_unique<Impl>(model_path)) {}
Detector::~Detector() = default;
Detector::Detector(Detector&&) noexcept = default;
Detector& Detector::operator=(Detector&&) noexcept = default;

std::vector<Box> Detector::DetectDepth(const std::vector<float>& depth_m,
                                       const Camera& camera,
                                       const std::optional<Pose>& world_from_camera) const {
  furn::Require(camera.width > 0 && camera.height > 0 &&
                    static_cast<uint64_t>(camera.width) * camera.height <= (uint64_t{1} << 24),
                "camera size " + std::to_string(camera.width) + " x " +
                    std::to_string(camera.height) + " must be positive and at most 2^24 pixels");
  furn::Require(depth_m.size() == static_cast<size_t>(camera.width) * camera.height,
                "depth has " + std::to_string(depth_m.size()) + " values, the camera " +
                    std::to_string(camera.width) + " x " + std::to_string(camera.height));
  furn::Require(camera.fx > 0 && camera.fy > 0 && std::isfinite(camera.fx) &&
                    std::isfinite(camera.fy) && std::isfinite(camera.cx) &&
                    std::isfinite(camera.cy),
                "camera fx, fy must be positive and fx, fy, cx, cy finite");
  furn::DepthFrame frame;
  frame.Reshape(camera.width, camera.height);
  for (size_t i = 0; i < depth_m.size(); ++i)
    frame.depth[i] = std::isfinite(depth_m[i]) && depth_m[i] > 0 ? depth_m[i] : 0.0f;
  furn::DetectionInput input;
  input.points = furn::BackProject(
      frame,
      furn::CameraIntrinsics{
          camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy});
  input.width = camera.width;
  input.height = camera.height;
  if (world_from_camera) input.world_from_camera = IsometryOf(*world_from_camera);
  return impl_->Run(input);
}

std::vector<Box> Detector::DetectPoints(const std::vector<std::array<float, 3>>& points,
                                        const std::optional<Pose>& world_from_camera) const {
  furn::DetectionInput input;
  input.points.reserve(points.size());
  for (const std::array<float, 3>& p : points) input.points.emplace_back(p[0], p[1], p[2]);
  if (world_from_camera) input.world_from_camera = IsometryOf(*world_from_camera);
  return impl_->Run(input);
}

Pose Detector::LastWorldFromCamera() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Pose rows{};
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) rows[4 * r + c] = impl_->last_pose.matrix()(r, c);
  }
  return rows;
}

std::map<std::string, double> EvaluateDetections(const std::string& detections_path,
                                                 const std::string& db_path,
                                                 const std::string& split) {
  furn::EvaluateCommandOptions options;
  options.split = furn::ParseSplit(split, "split");
  return furn::EvaluateDetections(detections_path, db_path, options).result.metrics;
}

}  // namespace furnidet
