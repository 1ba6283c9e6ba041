// The ROS 2 message definitions of the types written here, as MCAP "ros2msg"
// schemas carry them (the type's fields, then each type it uses after a line
// of 80 '=' and "MSG: package/Type"), and the QoS profiles rosbag2 records.
// The fields are those ros2_messages.cc encodes (Humble and later).
#include <map>
#include <set>
#include <string>
#include <vector>

#include "workbench/formats/ros2_messages.h"

namespace furn {
namespace {

struct Definition {
  const char* fields;
  std::vector<const char*> uses;  // the types named in `fields`
};

const std::map<std::string, Definition>& Definitions() {
  static const std::map<std::string, Definition> definitions = {
      {"builtin_interfaces/Time", {"int32 sec\nuint32 nanosec\n", {}}},
      {"builtin_interfaces/Duration", {"int32 sec\nuint32 nanosec\n", {}}},
      {"std_msgs/Header",
       {"builtin_interfaces/Time stamp\nstring frame_id\n", {"builtin_interfaces/Time"}}},
      {"std_msgs/ColorRGBA", {"float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n", {}}},
      {"geometry_msgs/Vector3", {"float64 x\nfloat64 y\nfloat64 z\n", {}}},
      {"geometry_msgs/Point", {"float64 x\nfloat64 y\nfloat64 z\n", {}}},
      {"geometry_msgs/Quaternion", {"float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n", {}}},
      {"geometry_msgs/Pose",
       {"geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
        {"geometry_msgs/Point", "geometry_msgs/Quaternion"}}},
      {"geometry_msgs/PoseWithCovariance",
       {"geometry_msgs/Pose pose\nfloat64[36] covariance\n", {"geometry_msgs/Pose"}}},
      {"geometry_msgs/Transform",
       {"geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n",
        {"geometry_msgs/Vector3", "geometry_msgs/Quaternion"}}},
      {"geometry_msgs/TransformStamped",
       {"std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
        {"std_msgs/Header", "geometry_msgs/Transform"}}},
      {"tf2_msgs/TFMessage",
       {"geometry_msgs/TransformStamped[] transforms\n", {"geometry_msgs/TransformStamped"}}},
      {"sensor_msgs/Image",
       {"std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 "
        "is_bigendian\nuint32 step\nuint8[] data\n",
        {"std_msgs/Header"}}},
      {"sensor_msgs/CompressedImage",
       {"std_msgs/Header header\nstring format\nuint8[] data\n", {"std_msgs/Header"}}},
      {"sensor_msgs/RegionOfInterest",
       {"uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n", {}}},
      {"sensor_msgs/CameraInfo",
       {"std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] "
        "d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 "
        "binning_y\nsensor_msgs/RegionOfInterest roi\n",
        {"std_msgs/Header", "sensor_msgs/RegionOfInterest"}}},
      {"sensor_msgs/PointField",
       {"uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 "
        "UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 "
        "datatype\nuint32 count\n",
        {}}},
      {"sensor_msgs/PointCloud2",
       {"std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] "
        "fields\nbool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool "
        "is_dense\n",
        {"std_msgs/Header", "sensor_msgs/PointField"}}},
      {"visualization_msgs/UVCoordinate", {"float32 u\nfloat32 v\n", {}}},
      {"visualization_msgs/MeshFile", {"string filename\nuint8[] data\n", {}}},
      {"visualization_msgs/Marker",
       {"int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\n"
        "int32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\n"
        "int32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\n"
        "int32 ARROW_STRIP=12\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n"
        "std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n"
        "geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n"
        "builtin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\n"
        "std_msgs/ColorRGBA[] colors\nstring texture_resource\nsensor_msgs/CompressedImage "
        "texture\nvisualization_msgs/UVCoordinate[] uv_coordinates\nstring text\nstring "
        "mesh_resource\nvisualization_msgs/MeshFile mesh_file\nbool mesh_use_embedded_materials\n",
        {"std_msgs/Header",
         "geometry_msgs/Pose",
         "geometry_msgs/Vector3",
         "std_msgs/ColorRGBA",
         "builtin_interfaces/Duration",
         "geometry_msgs/Point",
         "sensor_msgs/CompressedImage",
         "visualization_msgs/UVCoordinate",
         "visualization_msgs/MeshFile"}}},
      {"visualization_msgs/MarkerArray",
       {"visualization_msgs/Marker[] markers\n", {"visualization_msgs/Marker"}}},
      {"vision_msgs/ObjectHypothesis", {"string class_id\nfloat64 score\n", {}}},
      {"vision_msgs/ObjectHypothesisWithPose",
       {"vision_msgs/ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose\n",
        {"vision_msgs/ObjectHypothesis", "geometry_msgs/PoseWithCovariance"}}},
      {"vision_msgs/BoundingBox3D",
       {"geometry_msgs/Pose center\ngeometry_msgs/Vector3 size\n",
        {"geometry_msgs/Pose", "geometry_msgs/Vector3"}}},
      {"vision_msgs/Detection3D",
       {"std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] "
        "results\nvision_msgs/BoundingBox3D bbox\nstring id\n",
        {"std_msgs/Header", "vision_msgs/ObjectHypothesisWithPose", "vision_msgs/BoundingBox3D"}}},
      {"vision_msgs/Detection3DArray",
       {"std_msgs/Header header\nvision_msgs/Detection3D[] detections\n",
        {"std_msgs/Header", "vision_msgs/Detection3D"}}},
  };
  return definitions;
}

// "sensor_msgs/msg/Image" -> "sensor_msgs/Image".
std::string ShortName(const std::string& type) {
  const size_t msg = type.find("/msg/");
  return msg == std::string::npos ? type : type.substr(0, msg) + type.substr(msg + 4);
}

// The types `type` uses, depth first, each once.
void Dependencies(const std::string& type,
                  std::set<std::string>* seen,
                  std::vector<std::string>* out) {
  for (const char* used : Definitions().at(type).uses) {
    if (!seen->insert(used).second) continue;
    out->push_back(used);
    Dependencies(used, seen, out);
  }
}

}  // namespace

std::string Ros2MessageDefinition(const std::string& type) {
  const std::string name = ShortName(type);
  const auto found = Definitions().find(name);
  if (found == Definitions().end()) return "";
  std::string text = found->second.fields;
  std::set<std::string> seen{name};
  std::vector<std::string> uses;
  Dependencies(name, &seen, &uses);
  for (const std::string& used : uses)
    text += std::string(80, '=') + "\nMSG: " + used + "\n" + Definitions().at(used).fields;
  return text;
}

std::string Ros2OfferedQos(bool latched) {
  // rosbag2's YAML of one publisher's offered profile (history unknown,
  // reliable, volatile or transient local, durations infinite), as Humble
  // and later record it.
  const std::string infinite = "\n    sec: 9223372036\n    nsec: 854775807";
  return "- history: 3\n  depth: 0\n  reliability: 1\n  durability: " +
         std::string(latched ? "1" : "2") + "\n  deadline:" + infinite +
         "\n  lifespan:" + infinite + "\n  liveliness: 1\n  liveliness_lease_duration:" + infinite +
         "\n  avoid_ros_namespace_conventions: false\n";
}

}  // namespace furn
