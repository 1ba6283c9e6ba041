#include "workbench/formats/rosbag_io.h"

#include "core/util/error.h"

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
#include <boost/make_shared.hpp>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>

#include "core/model/furniture_class.h"
#include "core/model/trained_model.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "reports/class_colours.h"
#include "workbench/formats/bag_check.h"
#include "workbench/formats/camera_file.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/point_fields.h"
#include "workbench/formats/ros_common.h"

namespace furn {
namespace {

std::string TimeText(const ros::Time& time) { return furn::TimeText(time.toSec()); }

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

RosHeader HeaderOf(const std_msgs::Header& header) {
  return {header.stamp.toSec(), header.frame_id, header.seq};
}

std_msgs::Header Ros1Header(const RosHeader& header) {
  std_msgs::Header out;
  out.stamp.fromSec(header.stamp);
  out.frame_id = header.frame_id;
  out.seq = header.seq;
  return out;
}

RosImage ImageOf(const sensor_msgs::Image& image) {
  return {HeaderOf(image.header),
          image.height,
          image.width,
          image.encoding,
          image.is_bigendian != 0,
          image.step,
          image.data};
}

RosCameraInfo InfoOf(const sensor_msgs::CameraInfo& info) {
  RosCameraInfo out;
  out.header = HeaderOf(info.header);
  out.width = info.width;
  out.height = info.height;
  std::copy(info.K.begin(), info.K.end(), out.k.begin());
  return out;
}

RosPointCloud2 CloudOf(const sensor_msgs::PointCloud2& cloud) {
  RosPointCloud2 out;
  out.header = HeaderOf(cloud.header);
  out.height = cloud.height;
  out.width = cloud.width;
  for (const auto& f : cloud.fields) out.fields.push_back({f.name, f.offset, f.datatype, f.count});
  out.is_bigendian = cloud.is_bigendian != 0;
  out.point_step = cloud.point_step;
  out.row_step = cloud.row_step;
  out.data = cloud.data;
  return out;
}

TfBuffer ReadTf(rosbag::Bag& bag, const std::string& path) {
  TfBuffer tf;
  try {
    rosbag::View view(
        bag, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static", "tf", "tf_static"}));
    for (const rosbag::MessageInstance& m : view) {
      if (m.getDataType() != "tf2_msgs/TFMessage") continue;
      const bool is_static = m.getTopic().find("tf_static") != std::string::npos;
      const std::string where = path + " " + m.getTopic();
      const auto message = CheckedInstantiate<tf2_msgs::TFMessage>(m, where);
      if (message == nullptr) continue;
      for (const geometry_msgs::TransformStamped& t : message->transforms) {
        RosTransform plain;
        plain.header = HeaderOf(t.header);
        plain.child_frame_id = t.child_frame_id;
        plain.translation << t.transform.translation.x, t.transform.translation.y,
            t.transform.translation.z;
        const auto& q = t.transform.rotation;
        plain.rotation = Eigen::Quaterniond(q.w, q.x, q.y, q.z);
        tf.Add(plain, is_static, where);
      }
    }
  } catch (...) {
    RethrowAsInputError(path + " /tf");
  }
  tf.Sort();
  return tf;
}

// A translation and rotation into ROS 1's x, y, z (Point, Vector3) and
// x, y, z, w (Quaternion) fields.
template <typename Xyz, typename Xyzw>
void SetRigid(const Eigen::Vector3d& t, const Eigen::Quaterniond& q, Xyz* xyz, Xyzw* xyzw) {
  xyz->x = t.x();
  xyz->y = t.y();
  xyz->z = t.z();
  xyzw->w = q.w();
  xyzw->x = q.x();
  xyzw->y = q.y();
  xyzw->z = q.z();
}

visualization_msgs::Marker Ros1Marker(const RosMarker& m) {
  visualization_msgs::Marker marker;
  marker.header = Ros1Header(m.header);
  marker.ns = m.ns;
  marker.id = m.id;
  marker.type = m.type;
  marker.action = m.action;
  SetRigid(m.pose.translation(),
           Eigen::Quaterniond(m.pose.linear()),
           &marker.pose.position,
           &marker.pose.orientation);
  marker.scale.x = m.scale.x();
  marker.scale.y = m.scale.y();
  marker.scale.z = m.scale.z();
  marker.color.r = m.rgba[0];
  marker.color.g = m.rgba[1];
  marker.color.b = m.rgba[2];
  marker.color.a = m.rgba[3];
  marker.text = m.text;
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
void FirstCameraInfo(rosbag::Bag& bag,
                     const std::string& info_topic,
                     const std::string& where,
                     BagScanAssembler* scans) {
  rosbag::View info_view(bag, rosbag::TopicQuery(info_topic));
  for (const rosbag::MessageInstance& m : info_view) {
    if (const auto info = CheckedInstantiate<sensor_msgs::CameraInfo>(m, where)) {
      scans->OnCameraInfo(InfoOf(*info), where);
      return;
    }
  }
}

// A message of the scan topic as a scan.
BagScan ScanOfMessage(const rosbag::MessageInstance& m,
                      const std::string& type,
                      const BagScanAssembler& scans,
                      const std::string& where) {
  if (type == "sensor_msgs/PointCloud2") {
    const auto cloud = CheckedInstantiate<sensor_msgs::PointCloud2>(m, where);
    Require(cloud != nullptr, where + ": not a sensor_msgs/PointCloud2");
    return scans.OnCloud(CloudOf(*cloud), m.getTopic(), m.getTime().toSec());
  }
  const auto image = CheckedInstantiate<sensor_msgs::Image>(m, where);
  Require(image != nullptr, where + ": not a sensor_msgs/Image");
  return scans.OnImage(ImageOf(*image), m.getTopic(), m.getTime().toSec(), where);
}

}  // namespace

int ForEachBagScan(const BagScanOptions& options, const std::function<void(const BagScan&)>& each) {
  CheckBagScanOptions(options);
  rosbag::Bag bag;
  OpenBag(options.bag_path, &bag);
  const TfBuffer tf = options.world_frame.empty() ? TfBuffer() : ReadTf(bag, options.bag_path);
  const std::string info_topic = CameraInfoTopic(options);
  BagScanAssembler scans(options, &tf, info_topic);
  int count = 0;
  try {
    const std::string type = TopicType(bag, options);
    if (type == "sensor_msgs/Image")
      FirstCameraInfo(bag, info_topic, options.bag_path + " " + info_topic, &scans);
    const int total = static_cast<int>(rosbag::View(bag, rosbag::TopicQuery(options.topic)).size());
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{options.topic, info_topic}));
    for (const rosbag::MessageInstance& m : view) {
      const std::string where =
          options.bag_path + " " + m.getTopic() + " at " + TimeText(m.getTime());
      if (m.getTopic() == info_topic && m.getTopic() != options.topic) {
        if (const auto info = CheckedInstantiate<sensor_msgs::CameraInfo>(m, where))
          scans.OnCameraInfo(InfoOf(*info), where);
        continue;
      }
      BagScan scan = ScanOfMessage(m, type, scans, where);
      scan.total = total;
      each(scan);
      ++count;
    }
  } catch (...) {
    RethrowAsInputError(options.bag_path);
  }
  return count;
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
  // The copy keeps the input's chunk compression (a marked LZ4 bag stays
  // LZ4, not five times its size).
  const std::string compression = CheckBagFile(in_bag);
  try {
    impl_->out.open(impl_->temporary, rosbag::bagmode::Write);
    impl_->out.setCompression(compression == "lz4"   ? rosbag::compression::LZ4
                              : compression == "bz2" ? rosbag::compression::BZ2
                                                     : rosbag::compression::Uncompressed);
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
  const double seconds = scan.stamp > 0 ? scan.stamp : scan.bag_time;
  char text_of_time[64];
  std::snprintf(text_of_time, sizeof(text_of_time), "%.17g", seconds);
  Require(seconds >= 0 && seconds < 4294967295.0,
          scan.loaded.description + ": its time stamp " + text_of_time +
              " s lies outside ROS time (0 to 2^32 s): no marker can carry it");
  RosHeader header;
  header.stamp = seconds;
  header.frame_id = MarkerFrame(scan, impl_->world_frame);
  for (const RosMarker& m : DetectionMarkers(result, model, header, FrameFromWorld(scan, result)))
    markers.markers.push_back(Ros1Marker(m));
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

sensor_msgs::Image Ros1Image(const RosImage& image) {
  sensor_msgs::Image out;
  out.header = Ros1Header(image.header);
  out.width = image.width;
  out.height = image.height;
  out.encoding = image.encoding;
  out.is_bigendian = image.is_bigendian;
  out.step = image.step;
  out.data = image.data;
  return out;
}

sensor_msgs::CameraInfo Ros1CameraInfo(const RosCameraInfo& info) {
  sensor_msgs::CameraInfo out;
  out.header = Ros1Header(info.header);
  out.width = info.width;
  out.height = info.height;
  out.distortion_model = info.distortion_model;
  out.D = info.d;
  std::copy(info.k.begin(), info.k.end(), out.K.begin());
  std::copy(info.r.begin(), info.r.end(), out.R.begin());
  std::copy(info.p.begin(), info.p.end(), out.P.begin());
  return out;
}

visualization_msgs::MarkerArray Ros1Markers(const std::vector<RosMarker>& markers) {
  visualization_msgs::MarkerArray out;
  for (const RosMarker& m : markers) out.markers.push_back(Ros1Marker(m));
  return out;
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

namespace {

// One transform as a TF message stamped `stamp`.
tf2_msgs::TFMessage Ros1TfMessage(const RosTransform& t, const ros::Time& stamp) {
  geometry_msgs::TransformStamped transform;
  transform.header.stamp = stamp;
  transform.header.frame_id = t.header.frame_id;
  transform.child_frame_id = t.child_frame_id;
  SetRigid(
      t.translation, t.rotation, &transform.transform.translation, &transform.transform.rotation);
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(transform);
  return tf;
}

// A connection header that marks a topic latched (rosbag records it so).
template <typename Message>
boost::shared_ptr<ros::M_string> Latched() {
  auto header = boost::make_shared<ros::M_string>();
  (*header)["topic"] = "/tf_static";
  (*header)["type"] = ros::message_traits::datatype<Message>();
  (*header)["md5sum"] = ros::message_traits::md5sum<Message>();
  (*header)["message_definition"] = ros::message_traits::definition<Message>();
  (*header)["callerid"] = "/furnidet_export";
  (*header)["latching"] = "1";
  return header;
}

}  // namespace

void FrameBagWriter::Write(const RoomRecord& room,
                           const FrameRecord& frame,
                           const std::string& where) {
  try {
    const int written = impl_->frames;
    const RecordedFrame recorded = RecordFrame(room, frame, written, where);
    // Whole tenths of seconds as ROS 1 time: no rounding through a double.
    const ros::Time stamp(1 + written / 10, (written % 10) * 100000000);
    sensor_msgs::Image image = Ros1Image(recorded.depth), ids = Ros1Image(recorded.ids);
    sensor_msgs::CameraInfo info = Ros1CameraInfo(recorded.info);
    image.header.stamp = ids.header.stamp = info.header.stamp = stamp;
    if (written == 0) {  // once, latched as tf2's static broadcaster publishes it
      impl_->bag.write("/tf_static",
                       stamp,
                       Ros1TfMessage(recorded.camera_from_optical, stamp),
                       Latched<tf2_msgs::TFMessage>());
    }
    const tf2_msgs::TFMessage tf = Ros1TfMessage(recorded.world_from_camera, stamp);
    visualization_msgs::MarkerArray truth = Ros1Markers(recorded.truth);
    for (visualization_msgs::Marker& m : truth.markers) m.header.stamp = stamp;
    impl_->bag.write("/tf", stamp, tf);
    impl_->bag.write("/camera/depth/camera_info", stamp, info);
    impl_->bag.write("/camera/depth/image_raw", stamp, image);
    impl_->bag.write("/camera/depth/ids", stamp, ids);
    impl_->bag.write("/furnidet/ground_truth", stamp, truth);
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
