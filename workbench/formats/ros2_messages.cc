#include "workbench/formats/ros2_messages.h"

#include <cmath>

#include "core/util/error.h"
#include "workbench/formats/cdr.h"

namespace furn {
namespace {

// Every decoded message must use all of its bytes but CDR's closing padding
// (at most 3 bytes): trailing data means a different type.
void RequireEnd(const CdrReader& in) {
  Require(in.remaining() < 4,
          in.where() + ": " + std::to_string(in.remaining()) +
              " bytes left after the message: not the type the topic names");
}

RosHeader ReadHeader(CdrReader& in) {
  RosHeader header;
  const int32_t sec = in.Read<int32_t>("header.stamp.sec");
  const uint32_t nanosec = in.Read<uint32_t>("header.stamp.nanosec");
  Require(nanosec < 1000000000u,
          in.where() + ": header.stamp.nanosec " + std::to_string(nanosec) + " must be < 1e9");
  header.stamp = sec + nanosec * 1e-9;
  header.frame_id = in.String("header.frame_id", 256);
  return header;
}

template <size_t N>
void ReadDoubles(CdrReader& in, const char* field, std::array<double, N>* out) {
  for (double& v : *out) v = in.Read<double>(field);
}

void WriteTime(CdrWriter& out, double seconds) {
  const auto [sec, nanosec] = Ros2Time(seconds, "a message");
  out.Write<int32_t>(sec);
  out.Write<uint32_t>(nanosec);
}

void WriteHeader(CdrWriter& out, const RosHeader& header) {
  WriteTime(out, header.stamp);
  out.String(header.frame_id);
}

void WritePose(CdrWriter& out, const Eigen::Isometry3d& pose) {
  const Eigen::Vector3d& t = pose.translation();
  const Eigen::Quaterniond q(pose.linear());
  for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) out.Write<double>(v);
}

void WriteVector3(CdrWriter& out, const Eigen::Vector3d& v) {
  for (double x : {v.x(), v.y(), v.z()}) out.Write<double>(x);
}

}  // namespace

std::pair<int32_t, uint32_t> Ros2Time(double seconds, const std::string& where) {
  Require(std::isfinite(seconds) && seconds >= 0 && seconds < 2147483647.0,
          where + ": time stamp " + std::to_string(seconds) +
              " s lies outside ROS 2 time (0 to 2^31 s)");
  int64_t nanoseconds = std::llround(seconds * 1e9);
  return {static_cast<int32_t>(nanoseconds / 1000000000),
          static_cast<uint32_t>(nanoseconds % 1000000000)};
}

RosImage DecodeImage(const std::vector<uint8_t>& cdr, const std::string& where) {
  CdrReader in(cdr.data(), cdr.size(), where);
  RosImage image;
  image.header = ReadHeader(in);
  image.height = in.Read<uint32_t>("height");
  image.width = in.Read<uint32_t>("width");
  image.encoding = in.String("encoding", 64);
  image.is_bigendian = in.ReadBool("is_bigendian");
  image.step = in.Read<uint32_t>("step");
  const auto [data, size] = in.Bytes("data");
  image.data.assign(data, data + size);
  RequireEnd(in);
  return image;
}

RosCameraInfo DecodeCameraInfo(const std::vector<uint8_t>& cdr, const std::string& where) {
  CdrReader in(cdr.data(), cdr.size(), where);
  RosCameraInfo info;
  info.header = ReadHeader(in);
  info.height = in.Read<uint32_t>("height");
  info.width = in.Read<uint32_t>("width");
  info.distortion_model = in.String("distortion_model", 64);
  info.d.resize(in.SequenceLength("d", 8));
  for (double& v : info.d) v = in.Read<double>("d");
  ReadDoubles(in, "k", &info.k);
  ReadDoubles(in, "r", &info.r);
  ReadDoubles(in, "p", &info.p);
  for (const char* field :
       {"binning_x", "binning_y", "roi.x_offset", "roi.y_offset", "roi.height", "roi.width"})
    in.Read<uint32_t>(field);
  in.ReadBool("roi.do_rectify");
  RequireEnd(in);
  return info;
}

RosPointCloud2 DecodePointCloud2(const std::vector<uint8_t>& cdr, const std::string& where) {
  CdrReader in(cdr.data(), cdr.size(), where);
  RosPointCloud2 cloud;
  cloud.header = ReadHeader(in);
  cloud.height = in.Read<uint32_t>("height");
  cloud.width = in.Read<uint32_t>("width");
  // A field is at least a 4-byte length, 1 byte of name, offset, type, count.
  cloud.fields.resize(in.SequenceLength("fields", 13));
  for (RosPointField& field : cloud.fields) {
    field.name = in.String("fields.name", 64);
    field.offset = in.Read<uint32_t>("fields.offset");
    field.datatype = in.Read<uint8_t>("fields.datatype");
    field.count = in.Read<uint32_t>("fields.count");
  }
  cloud.is_bigendian = in.ReadBool("is_bigendian");
  cloud.point_step = in.Read<uint32_t>("point_step");
  cloud.row_step = in.Read<uint32_t>("row_step");
  const auto [data, size] = in.Bytes("data");
  cloud.data.assign(data, data + size);
  cloud.is_dense = in.ReadBool("is_dense");
  RequireEnd(in);
  return cloud;
}

std::vector<RosTransform> DecodeTfMessage(const std::vector<uint8_t>& cdr,
                                          const std::string& where) {
  CdrReader in(cdr.data(), cdr.size(), where);
  // header (>= 12 bytes), child frame (>= 4), 7 doubles.
  std::vector<RosTransform> transforms(in.SequenceLength("transforms", 12 + 4 + 7 * 8));
  for (RosTransform& t : transforms) {
    t.header = ReadHeader(in);
    t.child_frame_id = in.String("child_frame_id", 256);
    for (int i = 0; i < 3; ++i) t.translation[i] = in.Read<double>("translation");
    const double x = in.Read<double>("rotation.x"), y = in.Read<double>("rotation.y"),
                 z = in.Read<double>("rotation.z"), w = in.Read<double>("rotation.w");
    t.rotation = Eigen::Quaterniond(w, x, y, z);
  }
  RequireEnd(in);
  return transforms;
}

std::vector<uint8_t> EncodeImage(const RosImage& image) {
  CdrWriter out;
  WriteHeader(out, image.header);
  out.Write<uint32_t>(image.height);
  out.Write<uint32_t>(image.width);
  out.String(image.encoding);
  out.WriteBool(image.is_bigendian);
  out.Write<uint32_t>(image.step);
  out.Bytes(image.data.data(), image.data.size());
  return out.Take();
}

std::vector<uint8_t> EncodeCameraInfo(const RosCameraInfo& info) {
  CdrWriter out;
  WriteHeader(out, info.header);
  out.Write<uint32_t>(info.height);
  out.Write<uint32_t>(info.width);
  out.String(info.distortion_model);
  out.SequenceLength(info.d.size());
  for (double v : info.d) out.Write<double>(v);
  for (double v : info.k) out.Write<double>(v);
  for (double v : info.r) out.Write<double>(v);
  for (double v : info.p) out.Write<double>(v);
  for (int i = 0; i < 6; ++i) out.Write<uint32_t>(0);  // binning x, y; roi
  out.WriteBool(false);                                // roi.do_rectify
  return out.Take();
}

std::vector<uint8_t> EncodePointCloud2(const RosPointCloud2& cloud) {
  CdrWriter out;
  WriteHeader(out, cloud.header);
  out.Write<uint32_t>(cloud.height);
  out.Write<uint32_t>(cloud.width);
  out.SequenceLength(cloud.fields.size());
  for (const RosPointField& field : cloud.fields) {
    out.String(field.name);
    out.Write<uint32_t>(field.offset);
    out.Write<uint8_t>(field.datatype);
    out.Write<uint32_t>(field.count);
  }
  out.WriteBool(cloud.is_bigendian);
  out.Write<uint32_t>(cloud.point_step);
  out.Write<uint32_t>(cloud.row_step);
  out.Bytes(cloud.data.data(), cloud.data.size());
  out.WriteBool(cloud.is_dense);
  return out.Take();
}

std::vector<uint8_t> EncodeTfMessage(const std::vector<RosTransform>& transforms) {
  CdrWriter out;
  out.SequenceLength(transforms.size());
  for (const RosTransform& t : transforms) {
    WriteHeader(out, t.header);
    out.String(t.child_frame_id);
    WriteVector3(out, t.translation);
    const Eigen::Quaterniond& q = t.rotation;
    for (double v : {q.x(), q.y(), q.z(), q.w()}) out.Write<double>(v);
  }
  return out.Take();
}

// visualization_msgs/msg/Marker of Humble and later: the texture and mesh
// fields (empty here) follow the colours.
std::vector<uint8_t> EncodeMarkerArray(const std::vector<RosMarker>& markers) {
  CdrWriter out;
  out.SequenceLength(markers.size());
  for (const RosMarker& m : markers) {
    WriteHeader(out, m.header);
    out.String(m.ns);
    out.Write<int32_t>(m.id);
    out.Write<int32_t>(m.type);
    out.Write<int32_t>(m.action);
    WritePose(out, m.pose);
    WriteVector3(out, m.scale);
    for (float c : m.rgba) out.Write<float>(c);
    out.Write<int32_t>(0);  // lifetime: forever
    out.Write<uint32_t>(0);
    out.WriteBool(false);           // frame_locked
    out.SequenceLength(0);          // points
    out.SequenceLength(0);          // colors
    out.String("");                 // texture_resource
    WriteHeader(out, RosHeader{});  // texture (CompressedImage): header,
    out.String("");                 //   format,
    out.SequenceLength(0);          //   data
    out.SequenceLength(0);          // uv_coordinates
    out.String(m.text);
    out.String("");         // mesh_resource
    out.String("");         // mesh_file.filename
    out.SequenceLength(0);  // mesh_file.data
    out.WriteBool(false);   // mesh_use_embedded_materials
  }
  return out.Take();
}

std::vector<uint8_t> EncodeDetection3DArray(const RosHeader& header,
                                            const std::vector<RosDetection3D>& detections) {
  CdrWriter out;
  WriteHeader(out, header);
  out.SequenceLength(detections.size());
  for (const RosDetection3D& d : detections) {
    WriteHeader(out, header);
    out.SequenceLength(1);  // results: one hypothesis
    out.String(d.class_id);
    out.Write<double>(d.score);
    WritePose(out, d.box_pose);  // hypothesis pose
    for (double v : d.covariance) out.Write<double>(v);
    WritePose(out, d.box_pose);  // bbox.center
    WriteVector3(out, d.size);   // bbox.size
    out.String(d.id);
  }
  return out.Take();
}

}  // namespace furn
