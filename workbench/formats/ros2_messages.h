// ROS 2 messages as CDR (the rosbag2 default serialization), for the plain
// message types of ros_common.h. Decoding is bounded (CdrReader) and throws
// InputError naming `where` and the field; layouts are those of ROS 2
// Humble and later (sensor_msgs, tf2_msgs, visualization_msgs, vision_msgs 4).
//
//   const RosImage image = DecodeImage(blob, "bag.db3 /camera/depth at 1.2");
//   const std::vector<uint8_t> blob = EncodeMarkerArray(markers);
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "workbench/formats/ros_common.h"

namespace furn {

// The ROS 2 type names.
inline constexpr char kRos2Image[] = "sensor_msgs/msg/Image";
inline constexpr char kRos2CameraInfo[] = "sensor_msgs/msg/CameraInfo";
inline constexpr char kRos2PointCloud2[] = "sensor_msgs/msg/PointCloud2";
inline constexpr char kRos2TfMessage[] = "tf2_msgs/msg/TFMessage";
inline constexpr char kRos2MarkerArray[] = "visualization_msgs/msg/MarkerArray";
inline constexpr char kRos2Detection3DArray[] = "vision_msgs/msg/Detection3DArray";

RosImage DecodeImage(const std::vector<uint8_t>& cdr, const std::string& where);
RosCameraInfo DecodeCameraInfo(const std::vector<uint8_t>& cdr, const std::string& where);
RosPointCloud2 DecodePointCloud2(const std::vector<uint8_t>& cdr, const std::string& where);
std::vector<RosTransform> DecodeTfMessage(const std::vector<uint8_t>& cdr,
                                          const std::string& where);

std::vector<uint8_t> EncodeImage(const RosImage& image);
std::vector<uint8_t> EncodeCameraInfo(const RosCameraInfo& info);
std::vector<uint8_t> EncodePointCloud2(const RosPointCloud2& cloud);
std::vector<uint8_t> EncodeTfMessage(const std::vector<RosTransform>& transforms);
std::vector<uint8_t> EncodeMarkerArray(const std::vector<RosMarker>& markers);
std::vector<uint8_t> EncodeDetection3DArray(const RosHeader& header,
                                            const std::vector<RosDetection3D>& detections);

// The definition of a type written here as an MCAP "ros2msg" schema holds it
// (its fields, then every type it uses); empty for other types.
std::string Ros2MessageDefinition(const std::string& type);

// rosbag2's offered_qos_profiles YAML of one publisher: reliable, and
// transient local when `latched` (/tf_static), else volatile.
std::string Ros2OfferedQos(bool latched);

// Seconds as ROS 2 time (int32 sec, uint32 nanosec), rounded to the
// nanosecond; InputError naming `where` outside 0..2^31 s.
std::pair<int32_t, uint32_t> Ros2Time(double seconds, const std::string& where);

}  // namespace furn
