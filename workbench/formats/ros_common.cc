#include "workbench/formats/ros_common.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>

#include "core/detector/detection_box.h"
#include "core/model/furniture_class.h"
#include "core/util/error.h"
#include "reports/class_colours.h"
#include "workbench/formats/camera_file.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/point_fields.h"

namespace furn {
namespace {

std::string StripSlash(const std::string& frame) {
  return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
}

}  // namespace

std::string TimeText(double seconds) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3f", seconds);
  return text;
}

void TfBuffer::Add(const RosTransform& t, bool is_static, const std::string& where) {
  const Eigen::Vector3d& p = t.translation;
  const double norm = t.rotation.coeffs().norm();
  char text[160];
  std::snprintf(text,
                sizeof(text),
                " at %.3f: translation (%g, %g, %g), rotation of norm %g; it must be finite, "
                "within 100 km, with a unit quaternion",
                t.header.stamp,
                p.x(),
                p.y(),
                p.z(),
                norm);
  Require(p.allFinite() && p.cwiseAbs().maxCoeff() <= 1e5 && std::isfinite(norm) &&
              std::abs(norm - 1) < 0.01,
          where + ": transform " + StripSlash(t.header.frame_id).substr(0, 64) + " -> " +
              StripSlash(t.child_frame_id).substr(0, 64) + text);
  Edge& edge = edges_[StripSlash(t.child_frame_id)];
  edge.parent = StripSlash(t.header.frame_id);
  edge.samples.push_back({is_static ? -std::numeric_limits<double>::infinity() : t.header.stamp,
                          t.rotation.normalized(),
                          p});
}

void TfBuffer::Sort() {
  for (auto& [child, edge] : edges_) {
    std::stable_sort(edge.samples.begin(), edge.samples.end(), [](const auto& a, const auto& b) {
      return a.time < b.time;
    });
  }
}

std::vector<std::string> TfBuffer::Roots() const {
  std::set<std::string> roots;
  for (const auto& [child, edge] : edges_) {
    if (edges_.count(edge.parent) == 0) roots.insert(edge.parent);
  }
  return {roots.begin(), roots.end()};
}

std::optional<Eigen::Isometry3d> TfBuffer::Lookup(const std::string& target,
                                                  const std::string& source,
                                                  double time) const {
  Eigen::Isometry3d target_from_frame = Eigen::Isometry3d::Identity();
  std::string frame = StripSlash(source);
  for (int depth = 0; depth < 64; ++depth) {
    if (frame == StripSlash(target)) return target_from_frame;
    const auto it = edges_.find(frame);
    if (it == edges_.end() || it->second.samples.empty()) return std::nullopt;
    target_from_frame = At(it->second, time) * target_from_frame;
    frame = it->second.parent;
  }
  return std::nullopt;
}

// Interpolated between the samples around `time`, held at the ends.
Eigen::Isometry3d TfBuffer::At(const Edge& edge, double time) {
  const auto& s = edge.samples;
  auto after = std::lower_bound(
      s.begin(), s.end(), time, [](const Sample& a, double t) { return a.time < t; });
  const Sample* a = &s.front();
  const Sample* b = &s.front();
  double share = 0;
  if (after == s.end()) {
    a = b = &s.back();
  } else if (after != s.begin()) {
    a = &*(after - 1);
    b = &*after;
    share =
        std::isfinite(a->time) && b->time > a->time ? (time - a->time) / (b->time - a->time) : 1.0;
  } else {
    a = b = &*after;
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = a->rotation.slerp(share, b->rotation).toRotationMatrix();
  pose.translation() = (1 - share) * a->translation + share * b->translation;
  return pose;
}

DepthFrame DepthOfImage(const RosImage& image, double depth_scale, const std::string& where) {
  const uint64_t width = image.width, height = image.height;
  Require(width > 0 && height > 0 && width <= 16384 && height <= 16384 &&
              width * height <= kMaxDepthPixels,
          where + ": image size " + std::to_string(width) + "x" + std::to_string(height) +
              " must be 1..16384 a side and at most " + std::to_string(kMaxDepthPixels) +
              " pixels (4096 x 4096: what one frame's detection may cost)");
  const bool is16 = image.encoding == "16UC1" || image.encoding == "mono16";
  const bool is32f = image.encoding == "32FC1";
  Require(is16 || is32f,
          where + ": depth encoding '" + image.encoding.substr(0, 32) +
              "' must be 16UC1, mono16 or 32FC1");
  const uint64_t bytes = is16 ? 2 : 4;
  Require(image.step >= width * bytes,
          where + ": step " + std::to_string(image.step) + " is less than width x " +
              std::to_string(bytes));
  Require(image.data.size() >= height * image.step,
          where + ": data holds " + std::to_string(image.data.size()) +
              " bytes, less than height x step");
  Require(!image.is_bigendian, where + ": big-endian depth images are not supported");
  DepthFrame frame;
  frame.Resize(static_cast<int>(width), static_cast<int>(height));
  const double scale = is16 ? (depth_scale > 0 ? depth_scale : 1000.0) : 1.0;
  for (uint64_t v = 0; v < height; ++v) {
    const uint8_t* row = image.data.data() + v * image.step;
    for (uint64_t u = 0; u < width; ++u) {
      double z;
      if (is16) {
        uint16_t raw;
        std::memcpy(&raw, row + 2 * u, 2);
        z = raw / scale;
      } else {
        float raw;
        std::memcpy(&raw, row + 4 * u, 4);
        z = raw;
      }
      frame.depth[v * width + u] = std::isfinite(z) && z > 0 ? static_cast<float>(z) : 0.0f;
    }
  }
  return frame;
}

CameraIntrinsics IntrinsicsOfInfo(const RosCameraInfo& info, const std::string& where) {
  Require(info.width >= 1 && info.width <= 16384 && info.height >= 1 && info.height <= 16384,
          where + ": CameraInfo size " + std::to_string(info.width) + "x" +
              std::to_string(info.height) + " must be in 1..16384 each");
  return CameraFromMatrix(std::vector<double>(info.k.begin(), info.k.end()),
                          static_cast<int>(info.width),
                          static_cast<int>(info.height),
                          where + ": CameraInfo K");
}

std::string TopicNamespace(const std::string& topic) {
  const size_t slash = topic.rfind('/');
  return slash == std::string::npos ? std::string() : topic.substr(0, slash);
}

void CheckBagScanOptions(const BagScanOptions& options) {
  Require(!options.topic.empty(), "--bag needs --topic");
  Require(
      options.depth_scale >= 0 && std::isfinite(options.depth_scale) && options.depth_scale <= 1e6,
      "--depth-scale " + std::to_string(options.depth_scale) + " must be in 0..1e6");
}

std::string CameraInfoTopic(const BagScanOptions& options) {
  return options.camera_info_topic.empty() ? TopicNamespace(options.topic) + "/camera_info"
                                           : options.camera_info_topic;
}

std::string MarkerFrame(const BagScan& scan, const std::string& world_frame) {
  return scan.pose_from_tf ? world_frame : scan.frame_id;
}

Eigen::Isometry3d FrameFromWorld(const BagScan& scan, const DetectionResult& result) {
  return scan.pose_from_tf ? Eigen::Isometry3d::Identity() : result.world_from_camera.inverse();
}

void BagScanAssembler::OnCameraInfo(const RosCameraInfo& info, const std::string& where) {
  camera_ = IntrinsicsOfInfo(info, where);
}

BagScan BagScanAssembler::OnImage(const RosImage& image,
                                  const std::string& topic,
                                  double bag_time,
                                  const std::string& where) const {
  Require(camera_.has_value(),
          options_.bag_path + ": no sensor_msgs/CameraInfo on " + info_topic_ +
              " for the images of " + options_.topic + " (name it with --camera-info)");
  DepthFrame depth = DepthOfImage(image, options_.depth_scale, where);
  Require(depth.width == camera_->width && depth.height == camera_->height,
          where + ": the image is " + std::to_string(depth.width) + "x" +
              std::to_string(depth.height) + " but the CameraInfo of " + info_topic_ + " is for " +
              std::to_string(camera_->width) + "x" + std::to_string(camera_->height));
  BagScan scan;
  scan.topic = topic;
  scan.bag_time = bag_time;
  scan.loaded.input.points = BackProject(depth, *camera_);
  scan.loaded.input.width = depth.width;
  scan.loaded.input.height = depth.height;
  scan.loaded.camera = *camera_;
  scan.loaded.camera_source = "CameraInfo";
  return Finish(std::move(scan), image.header);
}

BagScan BagScanAssembler::OnCloud(const RosPointCloud2& cloud,
                                  const std::string& topic,
                                  double bag_time) const {
  BagScan scan;
  scan.topic = topic;
  scan.bag_time = bag_time;
  const std::string where = options_.bag_path + " " + topic + " at " + TimeText(bag_time);
  scan.loaded.input.points = DecodeXyz(PackedPointsOf(cloud), where);
  if (cloud.height > 1) {
    scan.loaded.input.width = static_cast<int>(cloud.width);
    scan.loaded.input.height = static_cast<int>(cloud.height);
  }
  scan = Finish(std::move(scan), cloud.header);
  if (IsBodyFrame(scan.frame_id)) TurnToOpticalAxes(&scan, where);
  return scan;
}

bool IsBodyFrame(const std::string& frame_id) {
  auto ends_with = [&](const std::string& tail) {
    return frame_id.size() >= tail.size() &&
           frame_id.compare(frame_id.size() - tail.size(), tail.size(), tail) == 0;
  };
  if (frame_id.find("optical") != std::string::npos) return false;
  for (const char* name : {"odom", "map", "world", "earth"}) {
    if (frame_id == name || frame_id == std::string("/") + name) return true;
  }
  return ends_with("_link") || ends_with("_footprint");
}

// A cloud in a REP 103 body frame (x forward, y left, z up), re-expressed in
// optical axes at the same origin (z forward, x right, y down), which the
// detector's floor search and camera model assume; only with a TF pose,
// since without one nothing says where the floor is.
void BagScanAssembler::TurnToOpticalAxes(BagScan* scan, const std::string& where) const {
  Require(scan->pose_from_tf,
          where + ": PointCloud2 in '" + scan->frame_id +
              "', a REP 103 body frame (x forward, z up), and " +
              (tf_ == nullptr || tf_->empty()
                   ? std::string("the bag has no /tf to place it")
                   : "TF has no chain from it to --tf-world '" + options_.world_frame + "'") +
              ": its floor cannot be found in body axes; record its TF (or name --tf-world) or "
              "the cloud in the camera's optical frame");
  const Eigen::Quaterniond body_from_optical = BodyFromOptical();
  const Eigen::Matrix3f optical_from_body =
      body_from_optical.conjugate().toRotationMatrix().cast<float>();
  for (Eigen::Vector3f& p : scan->loaded.input.points) p = optical_from_body * p;
  Eigen::Isometry3d world_from_optical = *scan->loaded.input.world_from_camera;
  world_from_optical.linear() = world_from_optical.linear() * body_from_optical.toRotationMatrix();
  scan->loaded.input.world_from_camera = world_from_optical;
  scan->loaded.pose_source += " (a body frame, turned to optical axes)";
}

BagScan BagScanAssembler::Finish(BagScan scan, const RosHeader& header) const {
  scan.frame_id = header.frame_id;
  scan.stamp = header.stamp;
  scan.seq = header.seq;
  scan.loaded.description = options_.bag_path + ":" + scan.topic + "@" + TimeText(header.stamp);
  if (tf_ != nullptr && !tf_->empty()) {
    const double time = scan.stamp == 0 ? scan.bag_time : scan.stamp;  // no header stamp
    if (const auto pose = tf_->Lookup(options_.world_frame, scan.frame_id, time)) {
      scan.loaded.input.world_from_camera = *pose;
      scan.loaded.pose_source = "tf: " + options_.world_frame + " <- " + scan.frame_id;
      scan.pose_from_tf = true;
    } else {
      std::string roots;
      for (const std::string& root : tf_->Roots()) roots += (roots.empty() ? "" : ", ") + root;
      scan.tf_miss = "TF has no chain from " + scan.frame_id + " to --tf-world '" +
                     options_.world_frame + "' (the TF tree's roots: " + roots +
                     "); the floor is estimated and the boxes are in the detector's own floor "
                     "frame";
    }
  }
  return scan;
}

namespace {

RosMarker DeleteAll(const RosHeader& header) {
  RosMarker marker;
  marker.header = header;
  marker.action = RosMarker::kDeleteAll;
  return marker;
}

// A translucent cube of `box` (a REP 103 box in the world) in the frame of
// `frame_from_world`.
RosMarker BoxMarker(const OrientedBox& box,
                    std::optional<FurnitureClass> furniture_class,
                    const Eigen::Isometry3d& frame_from_world) {
  RosMarker marker;
  marker.pose = frame_from_world * WorldFromBox(box);
  marker.scale = box.size.cwiseMax(0.01);
  const std::array<uint8_t, 3> rgb = ClassColourRgb(furniture_class);
  marker.rgba = {rgb[0] / 255.0f, rgb[1] / 255.0f, rgb[2] / 255.0f, 0.5f};
  return marker;
}

}  // namespace

std::vector<RosMarker> DetectionMarkers(const DetectionResult& result,
                                        const TrainedModel& model,
                                        const RosHeader& header,
                                        const Eigen::Isometry3d& frame_from_world) {
  std::vector<RosMarker> markers{DeleteAll(header)};
  int id = 0;
  for (const Detection& d : result.detections) {
    const std::string name = ClassName(d.furniture_class);
    const OrientedBox world_box = DetectionBoxInWorld(d, model);
    RosMarker box = BoxMarker(world_box, d.furniture_class, frame_from_world);
    box.header = header;
    box.ns = "furnidet/" + name;
    box.id = id++;
    RosMarker label = box;
    label.ns = "furnidet/labels";
    label.type = RosMarker::kText;
    char text[96];
    std::snprintf(text, sizeof(text), "%s %.2f", name.c_str(), d.score);
    label.text = text;
    if (d.in_view < 1) {  // cut by the frame: the centre is a guess from the part in view
      std::snprintf(text, sizeof(text), " (%.0f%% in view)", 100 * d.in_view);
      label.text += text;
    }
    label.pose.translation() =
        frame_from_world *
        (world_box.centre + Eigen::Vector3d(0, 0, world_box.size.z() / 2 + 0.15));
    label.scale = Eigen::Vector3d::Constant(0.15);
    label.rgba[3] = 1;
    markers.push_back(box);
    markers.push_back(label);
  }
  return markers;
}

std::vector<RosDetection3D> DetectionBoxes(const DetectionResult& result,
                                           const TrainedModel& model,
                                           const Eigen::Isometry3d& frame_from_world) {
  std::vector<RosDetection3D> boxes;
  for (const Detection& d : result.detections) {
    const OrientedBox box = DetectionBoxInWorld(d, model);
    RosDetection3D out;
    out.class_id = ClassName(d.furniture_class);
    out.id = std::to_string(boxes.size());
    out.score = d.score;
    out.box_pose = frame_from_world * WorldFromBox(box);
    out.size = box.size;
    boxes.push_back(out);
  }
  return boxes;
}

std::vector<RosMarker> TruthMarkers(const RoomRecord& room, double stamp) {
  RosHeader header;
  header.stamp = stamp;
  header.frame_id = "world";
  std::vector<RosMarker> markers{DeleteAll(header)};
  for (const ObjectRecord& object : room.objects) {
    RosMarker box = BoxMarker(WorldBoxOf(object.Footprint(), 0, object.height),
                              object.furniture_class,
                              Eigen::Isometry3d::Identity());
    box.header = header;
    box.ns = object.furniture_class ? ClassName(*object.furniture_class) : "clutter";
    box.id = static_cast<int32_t>(object.instance_id);
    box.text = object.model_id;
    markers.push_back(box);
  }
  return markers;
}

namespace {

RosImage Image16(const RosHeader& header, int width, int height, const uint16_t* values) {
  RosImage image;
  image.header = header;
  image.width = static_cast<uint32_t>(width);
  image.height = static_cast<uint32_t>(height);
  image.encoding = "16UC1";
  image.step = 2 * image.width;
  image.data.resize(size_t{image.step} * image.height);
  std::memcpy(image.data.data(), values, image.data.size());
  return image;
}

}  // namespace

Eigen::Quaterniond BodyFromOptical() {
  Eigen::Matrix3d body_from_optical;
  body_from_optical.col(0) = -Eigen::Vector3d::UnitY();  // optical x: right
  body_from_optical.col(1) = -Eigen::Vector3d::UnitZ();  // optical y: down
  body_from_optical.col(2) = Eigen::Vector3d::UnitX();   // optical z: forward
  Eigen::Quaterniond q(body_from_optical);
  if (q.w() < 0) q.coeffs() *= -1;  // as drivers publish it: (x, y, z, w) = (-0.5, 0.5, -0.5, 0.5)
  return q;
}

RecordedFrame RecordFrame(const RoomRecord& room,
                          const FrameRecord& frame,
                          int index,
                          const std::string& where) {
  RecordedFrame out;
  out.stamp = 1 + index / 10 + (index % 10) * 0.1;
  RosHeader header;
  header.stamp = out.stamp;
  header.frame_id = kExportCameraFrame;
  header.seq = static_cast<uint32_t>(frame.id);
  const DepthFrame depth = DecodeDepthPng(frame.depth_noisy_png, where);
  std::vector<uint16_t> mm(depth.depth.size());
  for (size_t i = 0; i < mm.size(); ++i)
    mm[i] = static_cast<uint16_t>(std::lround(depth.depth[i] * 1000.0));
  out.depth = Image16(header, depth.width, depth.height, mm.data());
  DepthFrame labels;
  labels.Resize(frame.width, frame.height);
  DecodeIdPng(frame.ids_png, where + " ids", &labels);
  out.ids = Image16(header, labels.width, labels.height, labels.instance_ids.data());
  out.info.header = header;
  out.info.width = static_cast<uint32_t>(frame.width);
  out.info.height = static_cast<uint32_t>(frame.height);
  out.info.k = {frame.fx, 0, frame.cx, 0, frame.fy, frame.cy, 0, 0, 1};
  out.info.r = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  out.info.p = {frame.fx, 0, frame.cx, 0, 0, frame.fy, frame.cy, 0, 0, 0, 1, 0};
  out.camera_from_optical.header = header;
  out.camera_from_optical.header.frame_id = kExportBodyFrame;
  out.camera_from_optical.child_frame_id = kExportCameraFrame;
  out.camera_from_optical.rotation = BodyFromOptical();
  out.world_from_camera.header = header;
  out.world_from_camera.header.frame_id = "world";
  out.world_from_camera.child_frame_id = kExportBodyFrame;
  out.world_from_camera.translation = frame.world_from_camera.translation();
  out.world_from_camera.rotation =
      Eigen::Quaterniond(frame.world_from_camera.linear()) * BodyFromOptical().conjugate();
  out.truth = TruthMarkers(room, out.stamp);
  return out;
}

}  // namespace furn
