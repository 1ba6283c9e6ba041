#include "workbench/formats/rosbag_io.h"

#include "core/error.h"

#ifndef FURN_WITH_ROS

namespace furn {

namespace {
[[noreturn]] void NoRos() {
  throw InputError(
      "this build reads and writes no ROS bags: install librosbag-dev, libsensor-msgs-dev, "
      "libvisualization-msgs-dev and libtf2-msgs-dev (tools/install_deps.sh) and rebuild");
}
}  // namespace

struct BagMarkerWriter::Impl {};
int ForEachBagScan(const BagScanOptions&, const std::function<void(const BagScan&)>&) { NoRos(); }
BagMarkerWriter::BagMarkerWriter(const std::string&, const std::string&, std::string, std::string) {
  NoRos();
}
BagMarkerWriter::~BagMarkerWriter() = default;
void BagMarkerWriter::Add(const BagScan&, const DetectionResult&, const TrainedModel&) { NoRos(); }
void BagMarkerWriter::Finish() { NoRos(); }
struct FrameBagWriter::Impl {};
FrameBagWriter::FrameBagWriter(const std::string&, bool) { NoRos(); }
FrameBagWriter::~FrameBagWriter() = default;
void FrameBagWriter::Write(const RoomRecord&, const FrameRecord&, const std::string&) { NoRos(); }
int FrameBagWriter::Finish() { NoRos(); }

}  // namespace furn

#else

#include <console_bridge/console.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>

#include "core/file_util.h"
#include "core/furniture_class.h"
#include "core/progress.h"
#include "core/trainer.h"
#include "db/dataset_db.h"
#include "reports/class_colours.h"
#include "workbench/formats/bag_check.h"
#include "workbench/formats/camera_file.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/point_fields.h"

namespace furn {
namespace {

constexpr char kCameraFrame[] = "camera_depth_optical_frame";

std::string TimeText(const ros::Time& time) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3f", time.toSec());
  return text;
}

// Our one line for whatever rosbag or a message's deserialisation threw.
[[noreturn]] void RethrowAsInputError(const std::string& where) {
  try {
    throw;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(where + ": " + e.what());
  }
}

// The message as T, after our bounded check of its serialized fields (the
// library allocates whatever a length field claims).
template <typename T>
boost::shared_ptr<T> CheckedInstantiate(const rosbag::MessageInstance& m,
                                        const std::string& where) {
  std::vector<uint8_t> bytes(m.size());
  ros::serialization::OStream stream(bytes.data(), static_cast<uint32_t>(bytes.size()));
  m.write(stream);
  CheckMessageFields(m.getDataType(), bytes, where);
  return m.instantiate<T>();
}

void OpenBag(const std::string& path, rosbag::Bag* bag) {
  RequireRegularFile(path);
  CheckBagFile(path);  // the library trusts every length and offset in the file
  // The library prints its own complaints (console_bridge); ours is the one
  // line the user sees.
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  try {
    bag->open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw InputError(path + ": not a readable ROS 1 bag (" + e.what() + ")");
  }
}

// /tf and /tf_static: every edge's transforms over time (parent_from_child).
class TfBuffer {
 public:
  // Throws InputError naming `where` and the transform for non-finite
  // values or a rotation that is not a unit quaternion (tf2 refuses them too).
  void Add(const tf2_msgs::TFMessage& message, bool is_static, const std::string& where) {
    for (const geometry_msgs::TransformStamped& t : message.transforms) {
      const auto& q = t.transform.rotation;
      const auto& p = t.transform.translation;
      Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
      const double norm = rotation.norm();
      char text[160];
      std::snprintf(text,
                    sizeof(text),
                    " at %.3f: translation (%g, %g, %g), rotation of norm %g; it must be finite "
                    "with a unit quaternion",
                    t.header.stamp.toSec(),
                    p.x,
                    p.y,
                    p.z,
                    norm);
      Require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) &&
                  std::isfinite(norm) && std::abs(norm - 1) < 0.01,
              where + ": transform " + Strip(t.header.frame_id).substr(0, 64) + " -> " +
                  Strip(t.child_frame_id).substr(0, 64) + text);
      Edge& edge = edges_[Strip(t.child_frame_id)];
      edge.parent = Strip(t.header.frame_id);
      edge.samples.push_back(
          {is_static ? -std::numeric_limits<double>::infinity() : t.header.stamp.toSec(),
           rotation.normalized(),
           Eigen::Vector3d(p.x, p.y, p.z)});
    }
  }
  void Sort() {
    for (auto& [child, edge] : edges_) {
      std::stable_sort(edge.samples.begin(), edge.samples.end(), [](const auto& a, const auto& b) {
        return a.time < b.time;
      });
    }
  }
  bool empty() const { return edges_.empty(); }

  // target_from_source at `time`, walking up from source; none when the
  // chain does not reach target.
  std::optional<Eigen::Isometry3d> Lookup(const std::string& target,
                                          const std::string& source,
                                          double time) const {
    Eigen::Isometry3d target_from_frame = Eigen::Isometry3d::Identity();
    std::string frame = Strip(source);
    for (int depth = 0; depth < 64; ++depth) {
      if (frame == Strip(target)) return target_from_frame;
      const auto it = edges_.find(frame);
      if (it == edges_.end() || it->second.samples.empty()) return std::nullopt;
      target_from_frame = At(it->second, time) * target_from_frame;
      frame = it->second.parent;
    }
    return std::nullopt;
  }

 private:
  struct Sample {
    double time;
    Eigen::Quaterniond rotation;
    Eigen::Vector3d translation;
  };
  struct Edge {
    std::string parent;
    std::vector<Sample> samples;
  };
  static std::string Strip(const std::string& frame) {
    return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
  }
  // Interpolated between the samples around `time`, held at the ends.
  static Eigen::Isometry3d At(const Edge& edge, double time) {
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
      share = std::isfinite(a->time) && b->time > a->time ? (time - a->time) / (b->time - a->time)
                                                          : 1.0;
    } else {
      a = b = &*after;
    }
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = a->rotation.slerp(share, b->rotation).toRotationMatrix();
    pose.translation() = (1 - share) * a->translation + share * b->translation;
    return pose;
  }
  std::map<std::string, Edge> edges_;
};

TfBuffer ReadTf(rosbag::Bag& bag, const std::string& path) {
  TfBuffer tf;
  try {
    rosbag::View view(
        bag, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static", "tf", "tf_static"}));
    for (const rosbag::MessageInstance& m : view) {
      if (m.getDataType() != "tf2_msgs/TFMessage") continue;
      const bool is_static = m.getTopic().find("tf_static") != std::string::npos;
      const std::string where = path + " " + m.getTopic();
      if (const auto message = CheckedInstantiate<tf2_msgs::TFMessage>(m, where))
        tf.Add(*message, is_static, where);
    }
  } catch (...) {
    RethrowAsInputError(path + " /tf");
  }
  tf.Sort();
  return tf;
}

// Camera-frame points of a PointCloud2: its x, y, z fields (FLOAT32 or FLOAT64).
DetectionInput PointsOf(const sensor_msgs::PointCloud2& cloud, const std::string& where) {
  DetectionInput input;
  input.points = DecodeXyz(PackedPointsOf(cloud), where);
  if (cloud.height > 1) {
    input.width = static_cast<int>(cloud.width);
    input.height = static_cast<int>(cloud.height);
  }
  return input;
}

CameraIntrinsics IntrinsicsOf(const sensor_msgs::CameraInfo& info, const std::string& where) {
  Require(info.width >= 1 && info.width <= 16384 && info.height >= 1 && info.height <= 16384,
          where + ": CameraInfo size " + std::to_string(info.width) + "x" +
              std::to_string(info.height) + " must be in 1..16384 each");
  return CameraFromMatrix(std::vector<double>(info.K.begin(), info.K.end()),
                          static_cast<int>(info.width),
                          static_cast<int>(info.height),
                          where + ": CameraInfo K");
}

DepthFrame DepthOf(const sensor_msgs::Image& image, double depth_scale, const std::string& where) {
  const uint64_t width = image.width, height = image.height;
  Require(width > 0 && height > 0 && width <= 16384 && height <= 16384,
          where + ": image size " + std::to_string(width) + "x" + std::to_string(height) +
              " must be 1..16384 a side");
  const bool is16 = image.encoding == "16UC1" || image.encoding == "mono16";
  const bool is32f = image.encoding == "32FC1";
  Require(is16 || is32f,
          where + ": depth encoding '" + image.encoding + "' must be 16UC1, mono16 or 32FC1");
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

std::string Namespace(const std::string& topic) {
  const size_t slash = topic.rfind('/');
  return slash == std::string::npos ? std::string() : topic.substr(0, slash);
}

void SetPose(const Eigen::Isometry3d& pose, geometry_msgs::Pose* out) {
  const Eigen::Quaterniond q(pose.linear());
  out->position.x = pose.translation().x();
  out->position.y = pose.translation().y();
  out->position.z = pose.translation().z();
  out->orientation.w = q.w();
  out->orientation.x = q.x();
  out->orientation.y = q.y();
  out->orientation.z = q.z();
}

void SetTransform(const Eigen::Isometry3d& pose, geometry_msgs::Transform* out) {
  const Eigen::Quaterniond q(pose.linear());
  out->translation.x = pose.translation().x();
  out->translation.y = pose.translation().y();
  out->translation.z = pose.translation().z();
  out->rotation.w = q.w();
  out->rotation.x = q.x();
  out->rotation.y = q.y();
  out->rotation.z = q.z();
}

// A cube for a box of `size` standing on the floor at (x, y) turned by yaw,
// in `frame_from_world` (identity: the world frame).
visualization_msgs::Marker BoxMarker(const std::string& ns,
                                     int id,
                                     std::optional<FurnitureClass> furniture_class,
                                     double x,
                                     double y,
                                     double yaw,
                                     const Eigen::Vector3d& size,
                                     const Eigen::Isometry3d& frame_from_world) {
  visualization_msgs::Marker marker;
  marker.ns = ns;
  marker.id = id;
  marker.type = visualization_msgs::Marker::CUBE;
  marker.action = visualization_msgs::Marker::ADD;
  Eigen::Isometry3d world_from_box = Eigen::Isometry3d::Identity();
  world_from_box.translation() = Eigen::Vector3d(x, y, size.z() / 2);
  world_from_box.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  SetPose(frame_from_world * world_from_box, &marker.pose);
  marker.scale.x = std::max(size.x(), 0.01);
  marker.scale.y = std::max(size.y(), 0.01);
  marker.scale.z = std::max(size.z(), 0.01);
  const std::array<uint8_t, 3> rgb = ClassColourRgb(furniture_class);
  marker.color.r = rgb[0] / 255.0f;
  marker.color.g = rgb[1] / 255.0f;
  marker.color.b = rgb[2] / 255.0f;
  marker.color.a = 0.5f;
  return marker;
}

visualization_msgs::Marker ClearMarkers() {
  visualization_msgs::Marker marker;
  marker.action = 3;  // DELETEALL (ROS Kinetic and later)
  return marker;
}

}  // namespace

namespace {

// The topic's message type, which must be PointCloud2 or Image.
std::string TopicType(rosbag::Bag& bag, const BagScanOptions& options) {
  std::string type;
  rosbag::View topic_view(bag, rosbag::TopicQuery(options.topic));
  for (const rosbag::ConnectionInfo* connection : topic_view.getConnections())
    type = connection->datatype;
  Require(!type.empty(), options.bag_path + ": no messages on topic " + options.topic);
  Require(type == "sensor_msgs/PointCloud2" || type == "sensor_msgs/Image",
          options.bag_path + ": topic " + options.topic + " is " + type +
              "; it must be sensor_msgs/PointCloud2 or sensor_msgs/Image");
  return type;
}

// The first CameraInfo of the topic, so an image recorded before its first
// CameraInfo still has intrinsics.
CameraIntrinsics FirstCameraInfo(rosbag::Bag& bag,
                                 const BagScanOptions& options,
                                 const std::string& info_topic) {
  rosbag::View info_view(bag, rosbag::TopicQuery(info_topic));
  for (const rosbag::MessageInstance& m : info_view) {
    if (const auto info =
            CheckedInstantiate<sensor_msgs::CameraInfo>(m, options.bag_path + " " + info_topic))
      return IntrinsicsOf(*info, options.bag_path + " " + info_topic);
  }
  throw InputError(options.bag_path + ": no sensor_msgs/CameraInfo on " + info_topic +
                   " for the images of " + options.topic + " (name it with --camera-info)");
}

// A message of the topic as a scan: a cloud's points, or an image's
// back-projected through the latest CameraInfo; its header's frame, stamp
// and sequence.
BagScan ScanOfMessage(const rosbag::MessageInstance& m,
                      const std::string& type,
                      const std::optional<CameraIntrinsics>& camera,
                      const BagScanOptions& options,
                      const std::string& info_topic,
                      const std::string& where) {
  BagScan scan;
  scan.topic = m.getTopic();
  scan.bag_time = m.getTime().toSec();
  std_msgs::Header header;
  if (type == "sensor_msgs/PointCloud2") {
    const sensor_msgs::PointCloud2::ConstPtr cloud =
        CheckedInstantiate<sensor_msgs::PointCloud2>(m, where);
    Require(cloud != nullptr, where + ": not a sensor_msgs/PointCloud2");
    scan.loaded.input = PointsOf(*cloud, where);
    header = cloud->header;
  } else {
    const sensor_msgs::Image::ConstPtr image = CheckedInstantiate<sensor_msgs::Image>(m, where);
    Require(image != nullptr, where + ": not a sensor_msgs/Image");
    DepthFrame depth = DepthOf(*image, options.depth_scale, where);
    Require(depth.width == camera->width && depth.height == camera->height,
            where + ": the image is " + std::to_string(depth.width) + "x" +
                std::to_string(depth.height) + " but the CameraInfo of " + info_topic + " is for " +
                std::to_string(camera->width) + "x" + std::to_string(camera->height));
    scan.loaded.input.points = BackProject(depth, *camera);
    scan.loaded.input.width = depth.width;
    scan.loaded.input.height = depth.height;
    scan.loaded.camera = *camera;
    header = image->header;
  }
  scan.frame_id = header.frame_id;
  scan.stamp = header.stamp.toSec();
  scan.seq = header.seq;
  scan.loaded.description = options.bag_path + ":" + scan.topic + "@" + TimeText(header.stamp);
  return scan;
}

}  // namespace

int ForEachBagScan(const BagScanOptions& options, const std::function<void(const BagScan&)>& each) {
  Require(!options.topic.empty(), "--bag needs --topic");
  Require(
      options.depth_scale >= 0 && std::isfinite(options.depth_scale) && options.depth_scale <= 1e6,
      "--depth-scale " + std::to_string(options.depth_scale) + " must be in 0..1e6");
  rosbag::Bag bag;
  OpenBag(options.bag_path, &bag);
  const TfBuffer tf = options.world_frame.empty() ? TfBuffer() : ReadTf(bag, options.bag_path);
  const std::string info_topic = options.camera_info_topic.empty()
                                     ? Namespace(options.topic) + "/camera_info"
                                     : options.camera_info_topic;
  int scans = 0;
  try {
    const std::string type = TopicType(bag, options);
    std::optional<CameraIntrinsics> camera;
    if (type == "sensor_msgs/Image") camera = FirstCameraInfo(bag, options, info_topic);
    const int total = static_cast<int>(rosbag::View(bag, rosbag::TopicQuery(options.topic)).size());
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{options.topic, info_topic}));
    for (const rosbag::MessageInstance& m : view) {
      const std::string where =
          options.bag_path + " " + m.getTopic() + " at " + TimeText(m.getTime());
      if (m.getTopic() == info_topic && m.getTopic() != options.topic) {
        if (const auto info = CheckedInstantiate<sensor_msgs::CameraInfo>(m, where))
          camera = IntrinsicsOf(*info, where);
        continue;
      }
      BagScan scan = ScanOfMessage(m, type, camera, options, info_topic, where);
      scan.total = total;
      if (!tf.empty()) {
        const double time = scan.stamp == 0 ? scan.bag_time : scan.stamp;  // no header stamp
        if (const auto pose = tf.Lookup(options.world_frame, scan.frame_id, time)) {
          scan.loaded.input.world_from_camera = *pose;
          scan.loaded.pose_source = "tf: " + options.world_frame + " <- " + scan.frame_id;
          scan.pose_from_tf = true;
        }
      }
      each(scan);
      ++scans;
    }
  } catch (...) {
    RethrowAsInputError(options.bag_path);
  }
  return scans;
}

struct BagMarkerWriter::Impl {
  std::string in_path, out_path, temporary, world_frame, marker_topic;
  rosbag::Bag out;
  bool finished = false;
};

BagMarkerWriter::BagMarkerWriter(const std::string& in_bag,
                                 const std::string& out_bag,
                                 std::string world_frame,
                                 std::string marker_topic)
    : impl_(std::make_unique<Impl>()) {
  impl_->in_path = in_bag;
  impl_->world_frame = std::move(world_frame);
  impl_->out_path = out_bag;
  impl_->marker_topic = std::move(marker_topic);
  impl_->temporary = out_bag + ".partial";
  std::error_code ec_in, ec_out;
  Require(std::filesystem::weakly_canonical(in_bag, ec_in) !=
                  std::filesystem::weakly_canonical(out_bag, ec_out) ||
              ec_in || ec_out,
          "--out-bag " + out_bag + " must not be the input bag");
  try {
    impl_->out.open(impl_->temporary, rosbag::bagmode::Write);
  } catch (const std::exception& e) {
    throw InputError(out_bag + ": cannot write the bag (" + e.what() + ")");
  }
}

BagMarkerWriter::~BagMarkerWriter() {
  if (impl_ == nullptr || impl_->finished) return;
  // Not finished (an error on the way): no half-written bag stays behind.
  try {
    impl_->out.close();
  } catch (...) {
  }
  std::error_code ec;
  std::filesystem::remove(impl_->temporary, ec);
}

void BagMarkerWriter::Add(const BagScan& scan,
                          const DetectionResult& result,
                          const TrainedModel& model) {
  visualization_msgs::MarkerArray markers;
  ros::Time stamp;
  const double seconds = scan.stamp > 0 ? scan.stamp : scan.bag_time;
  char text_of_time[64];
  std::snprintf(text_of_time, sizeof(text_of_time), "%.17g", seconds);
  Require(seconds >= 0 && seconds < 4294967295.0,
          scan.loaded.description + ": its time stamp " + text_of_time +
              " s lies outside ROS time (0 to 2^32 s): no marker can carry it");
  stamp.fromSec(seconds);
  // The world frame of TF, else the sensor's frame (the detector's floor
  // frame exists only inside this scan).
  const std::string& frame = scan.pose_from_tf ? impl_->world_frame : scan.frame_id;
  const Eigen::Isometry3d frame_from_world =
      scan.pose_from_tf ? Eigen::Isometry3d::Identity() : result.world_from_camera.inverse();
  markers.markers.push_back(ClearMarkers());
  int id = 0;
  for (const Detection& d : result.detections) {
    const std::string name = ClassName(d.furniture_class);
    const DetectionBox detection_box = BoxOf(d, model);
    const Eigen::Vector3d size = (detection_box.high - detection_box.low).cast<double>();
    visualization_msgs::Marker box = BoxMarker(
        "furnidet/" + name, id, d.furniture_class, d.x, d.y, d.yaw, size, frame_from_world);
    visualization_msgs::Marker label = box;
    label.ns = "furnidet/labels";
    label.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    char text[96];
    std::snprintf(text, sizeof(text), "%s %.2f", name.c_str(), d.score);
    label.text = text;
    label.pose.position.z += size.z() / 2 + 0.15;
    label.scale.x = label.scale.y = label.scale.z = 0.15;
    label.color.a = 1;
    for (visualization_msgs::Marker* m : {&box, &label}) {
      m->header.frame_id = frame;
      m->header.stamp = stamp;
      markers.markers.push_back(*m);
    }
    ++id;
  }
  markers.markers.front().header.frame_id = frame;
  markers.markers.front().header.stamp = stamp;
  ros::Time bag_time;
  bag_time.fromSec(scan.bag_time);
  try {
    impl_->out.write(impl_->marker_topic, bag_time, markers);
  } catch (const std::exception& e) {
    throw InputError(impl_->out_path + ": cannot write the bag (" + e.what() + ")");
  }
}

void BagMarkerWriter::Finish() {
  rosbag::Bag in;
  OpenBag(impl_->in_path, &in);
  try {
    rosbag::View view(in);
    for (const rosbag::MessageInstance& m : view) {
      if (m.getTopic() == impl_->marker_topic) continue;  // a rerun replaces the old markers
      impl_->out.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
    }
    impl_->out.close();
  } catch (const std::exception& e) {
    throw InputError(impl_->out_path + ": cannot write the bag (" + e.what() + ")");
  }
  std::error_code ec;
  std::filesystem::rename(impl_->temporary, impl_->out_path, ec);
  Require(!ec,
          impl_->out_path + ": cannot move the finished bag into place (" + ec.message() + ")");
  impl_->finished = true;
}

namespace {

sensor_msgs::Image DepthImage(const DepthFrame& depth, const std_msgs::Header& header) {
  sensor_msgs::Image image;
  image.header = header;
  image.width = depth.width;
  image.height = depth.height;
  image.encoding = "16UC1";
  image.is_bigendian = 0;
  image.step = 2 * depth.width;
  image.data.resize(image.step * image.height);
  for (size_t i = 0; i < depth.depth.size(); ++i) {
    const uint16_t mm = static_cast<uint16_t>(std::lround(depth.depth[i] * 1000.0));
    std::memcpy(&image.data[2 * i], &mm, 2);
  }
  return image;
}

sensor_msgs::CameraInfo CameraInfoOf(const FrameRecord& frame, const std_msgs::Header& header) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = frame.width;
  info.height = frame.height;
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  info.K = {frame.fx, 0, frame.cx, 0, frame.fy, frame.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {frame.fx, 0, frame.cx, 0, 0, frame.fy, frame.cy, 0, 0, 0, 1, 0};
  return info;
}

// A cube per object of the room, namespace its class or "clutter".
visualization_msgs::MarkerArray TruthMarkers(const RoomRecord& room, const ros::Time& stamp) {
  visualization_msgs::MarkerArray truth;
  truth.markers.push_back(ClearMarkers());
  truth.markers.front().header.frame_id = "world";
  truth.markers.front().header.stamp = stamp;
  for (const ObjectRecord& object : room.objects) {
    visualization_msgs::Marker box =
        BoxMarker(object.furniture_class ? ClassName(*object.furniture_class) : "clutter",
                  object.instance_id,
                  object.furniture_class,
                  object.reference_x,
                  object.reference_y,
                  object.yaw,
                  Eigen::Vector3d(object.width, object.depth, object.height),
                  Eigen::Isometry3d::Identity());
    box.header.frame_id = "world";
    box.header.stamp = stamp;
    box.text = object.model_id;
    truth.markers.push_back(box);
  }
  return truth;
}

}  // namespace

struct FrameBagWriter::Impl {
  std::string out_path, temporary;
  rosbag::Bag bag;
  int frames = 0;
  bool finished = false;
};

FrameBagWriter::FrameBagWriter(const std::string& out_bag, bool compress)
    : impl_(std::make_unique<Impl>()) {
  impl_->out_path = out_bag;
  impl_->temporary = out_bag + ".partial";
  try {
    impl_->bag.open(impl_->temporary, rosbag::bagmode::Write);
    impl_->bag.setCompression(compress ? rosbag::compression::LZ4
                                       : rosbag::compression::Uncompressed);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(impl_->temporary, ec);
    RethrowAsInputError(out_bag);
  }
}

FrameBagWriter::~FrameBagWriter() {
  if (impl_->finished) return;
  try {
    impl_->bag.close();
  } catch (...) {  // a destructor does not throw; the partial file goes anyway
  }
  std::error_code ec;
  std::filesystem::remove(impl_->temporary, ec);
}

void FrameBagWriter::Write(const RoomRecord& room,
                           const FrameRecord& frame,
                           const std::string& where) {
  try {
    const int written = impl_->frames;
    ros::Time stamp(1 + written / 10, (written % 10) * 100000000);
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = kCameraFrame;
    header.seq = static_cast<uint32_t>(frame.id);
    const sensor_msgs::Image image =
        DepthImage(DecodeDepthPng(frame.depth_noisy_png, where), header);
    sensor_msgs::Image ids = image;
    DepthFrame labels;
    labels.Resize(frame.width, frame.height);
    DecodeIdPng(frame.ids_png, where + " ids", &labels);
    std::memcpy(ids.data.data(), labels.instance_ids.data(), 2 * labels.instance_ids.size());
    tf2_msgs::TFMessage tf;
    geometry_msgs::TransformStamped transform;
    transform.header.stamp = stamp;
    transform.header.frame_id = "world";
    transform.child_frame_id = kCameraFrame;
    SetTransform(frame.world_from_camera, &transform.transform);
    tf.transforms.push_back(transform);
    impl_->bag.write("/tf", stamp, tf);
    impl_->bag.write("/camera/depth/camera_info", stamp, CameraInfoOf(frame, header));
    impl_->bag.write("/camera/depth/image_raw", stamp, image);
    impl_->bag.write("/camera/depth/ids", stamp, ids);
    impl_->bag.write("/furnidet/ground_truth", stamp, TruthMarkers(room, stamp));
    ++impl_->frames;
  } catch (...) {
    RethrowAsInputError(impl_->out_path);
  }
}

int FrameBagWriter::Finish() {
  try {
    impl_->bag.close();
  } catch (...) {
    RethrowAsInputError(impl_->out_path);
  }
  std::error_code ec;
  std::filesystem::rename(impl_->temporary, impl_->out_path, ec);
  Require(!ec,
          impl_->out_path + ": cannot move the finished bag into place (" + ec.message() + ")");
  impl_->finished = true;
  return impl_->frames;
}

}  // namespace furn

#endif  // FURN_WITH_ROS
