// What the ROS 1 and ROS 2 bag paths share, in plain types (no ROS headers):
// the messages this workbench reads and writes, the TF tree of a bag, a
// depth message turned into a scan, and the marker boxes of detections and
// of a room's truth. rosbag_io.cc converts ROS 1's message classes to and
// from these; ros2_messages.cc encodes and decodes them as CDR.
//
//   BagScanAssembler scans(options, tf);
//   scans.OnCameraInfo(info, where);
//   BagScan scan = scans.OnImage(image, "/camera/depth/image_raw", bag_time, where);
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/detector/detector.h"
#include "db/dataset_db.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/rosbag_io.h"

namespace furn {

struct RosHeader {
  double stamp = 0;  // seconds
  std::string frame_id;
  uint32_t seq = 0;  // ROS 1 only
};

struct RosImage {
  RosHeader header;
  uint32_t height = 0, width = 0;
  std::string encoding;
  bool is_bigendian = false;
  uint32_t step = 0;
  std::vector<uint8_t> data;
};

struct RosCameraInfo {
  RosHeader header;
  uint32_t height = 0, width = 0;
  std::string distortion_model = "plumb_bob";
  std::vector<double> d = std::vector<double>(5, 0.0);
  std::array<double, 9> k{}, r{};
  std::array<double, 12> p{};
};

struct RosPointField {
  std::string name;
  uint32_t offset = 0;
  uint8_t datatype = 0;
  uint32_t count = 1;
};

struct RosPointCloud2 {
  RosHeader header;
  uint32_t height = 0, width = 0;
  std::vector<RosPointField> fields;
  bool is_bigendian = false;
  uint32_t point_step = 0, row_step = 0;
  std::vector<uint8_t> data;
  bool is_dense = false;
};

struct RosTransform {
  RosHeader header;  // the parent frame
  std::string child_frame_id;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
};

// A visualization_msgs/Marker of the kinds written here (CUBE, TEXT_VIEW_FACING, DELETEALL).
struct RosMarker {
  enum Type : int32_t { kCube = 1, kText = 9 };
  enum Action : int32_t { kAdd = 0, kDeleteAll = 3 };
  RosHeader header;
  std::string ns;
  int32_t id = 0, type = kCube, action = kAdd;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d scale = Eigen::Vector3d::Zero();
  std::array<float, 4> rgba{};
  std::string text;
};

// One detection as vision_msgs/Detection3D: a box and one hypothesis.
struct RosDetection3D {
  std::string class_id;
  // Unique within its message: the detection's index in the message (and in
  // detect's JSON line of the same scan). Not a track id: detections of one
  // object in two messages do not share it (vision_msgs allows that).
  std::string id;
  double score = 0;
  Eigen::Isometry3d box_pose = Eigen::Isometry3d::Identity();  // box centre, x = the front
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  // The hypothesis pose's covariance (row-major x, y, z, rotations about x,
  // y, z). The detector estimates none, so it is marked unknown as
  // sensor_msgs does (first element -1, the rest 0).
  std::array<double, 36> covariance = UnknownCovariance();

  static std::array<double, 36> UnknownCovariance() {
    std::array<double, 36> unknown{};
    unknown[0] = -1;
    return unknown;
  }
};

// /tf and /tf_static: every edge's transforms over time (parent_from_child).
class TfBuffer {
 public:
  // Throws InputError naming `where` and the transform for non-finite
  // values or a rotation that is not a unit quaternion (tf2 refuses them too).
  void Add(const RosTransform& transform, bool is_static, const std::string& where);
  void Sort();
  bool empty() const { return edges_.empty(); }
  // The frames at the top of the tree (parents that are nobody's child),
  // sorted: what a floor-aligned world frame usually is (odom, map, world).
  std::vector<std::string> Roots() const;
  // target_from_source at `time`, walking up from source; none when the
  // chain does not reach target.
  std::optional<Eigen::Isometry3d> Lookup(const std::string& target,
                                          const std::string& source,
                                          double time) const;

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
  static Eigen::Isometry3d At(const Edge& edge, double time);
  std::map<std::string, Edge> edges_;
};

// A depth image's metres (16UC1/mono16 in 1/depth_scale m, 0: mm; 32FC1 in
// m); InputError naming `where` for sizes, encodings and data that do not fit.
DepthFrame DepthOfImage(const RosImage& image, double depth_scale, const std::string& where);
CameraIntrinsics IntrinsicsOfInfo(const RosCameraInfo& info, const std::string& where);
// A time in messages: seconds with 3 decimals ("12.250").
std::string TimeText(double seconds);
// The topic's namespace: "/camera/depth" of "/camera/depth/image_raw".
std::string TopicNamespace(const std::string& topic);

// Throws InputError for a missing topic or a depth scale outside 0..1e6.
void CheckBagScanOptions(const BagScanOptions& options);
// The CameraInfo topic of the options: named, or <the image's namespace>/camera_info.
std::string CameraInfoTopic(const BagScanOptions& options);
// Where a scan's detection markers go: the TF world frame when its pose came
// from TF, else the message's own frame (the detector's floor frame exists
// only inside the scan), with that frame's pose of the world.
std::string MarkerFrame(const BagScan& scan, const std::string& world_frame);
Eigen::Isometry3d FrameFromWorld(const BagScan& scan, const DetectionResult& result);

// Turns a bag's messages, in bag order, into scans: the latest CameraInfo
// gives an image its intrinsics, TF its pose.
// Whether a frame is a REP 103 body frame (x forward, y left, z up) by its
// name: *_link, *_footprint, odom, map, world, earth; never one named
// *optical*. Clouds in other frames are taken as optical (z forward).
bool IsBodyFrame(const std::string& frame_id);

class BagScanAssembler {
 public:
  BagScanAssembler(const BagScanOptions& options, const TfBuffer* tf, std::string info_topic)
      : options_(options), tf_(tf), info_topic_(std::move(info_topic)) {}
  void OnCameraInfo(const RosCameraInfo& info, const std::string& where);
  bool has_camera() const { return camera_.has_value(); }
  BagScan OnImage(const RosImage& image,
                  const std::string& topic,
                  double bag_time,
                  const std::string& where) const;
  BagScan OnCloud(const RosPointCloud2& cloud, const std::string& topic, double bag_time) const;

 private:
  BagScan Finish(BagScan scan, const RosHeader& header) const;
  void TurnToOpticalAxes(BagScan* scan, const std::string& where) const;
  const BagScanOptions& options_;
  const TfBuffer* tf_;
  std::string info_topic_;
  std::optional<CameraIntrinsics> camera_;
};

// A DELETEALL marker, then per detection a cube (namespace furnidet/<class>)
// and a label (furnidet/labels), in `frame` as seen from the world by
// `frame_from_world`, stamped `stamp`.
std::vector<RosMarker> DetectionMarkers(const DetectionResult& result,
                                        const TrainedModel& model,
                                        const RosHeader& header,
                                        const Eigen::Isometry3d& frame_from_world);
// The detections as boxes for vision_msgs/Detection3DArray, in the same frame.
std::vector<RosDetection3D> DetectionBoxes(const DetectionResult& result,
                                           const TrainedModel& model,
                                           const Eigen::Isometry3d& frame_from_world);
// A DELETEALL marker, then a cube per object of the room (namespace its class
// or "clutter", id its instance id, text its model), in "world".
std::vector<RosMarker> TruthMarkers(const RoomRecord& room, double stamp);

// What a Kinect driver would record of a dataset frame.
inline constexpr char kExportCameraFrame[] = "camera_depth_optical_frame";
inline constexpr char kExportBodyFrame[] = "camera_link";
// camera_link_from_optical of REP 103: optical z is the body's x, optical x
// its -y, optical y its -z.
Eigen::Quaterniond BodyFromOptical();
struct RecordedFrame {
  double stamp = 0;
  RosImage depth, ids;  // 16UC1 millimetres; 16UC1 instance ids
  RosCameraInfo info;
  // The TF tree a camera driver publishes: /tf world -> camera_link (REP 103
  // body frame, x forward, z up) per frame, and /tf_static camera_link ->
  // camera_depth_optical_frame (z forward, x right, y down), the images'.
  RosTransform world_from_camera;  // world -> camera_link
  RosTransform camera_from_optical;
  std::vector<RosMarker> truth;
};
// Frame number `index` of an export (0.1 s apart from t = 1 s).
RecordedFrame RecordFrame(const RoomRecord& room,
                          const FrameRecord& frame,
                          int index,
                          const std::string& where);

}  // namespace furn
