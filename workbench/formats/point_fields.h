// The one decoder of packed point records. PCD, PLY (as PCL reads them) and
// ROS sensor_msgs/PointCloud2 all lay a cloud out alike: height rows of
// row_step bytes, each holding width points of point_step bytes, a named
// field at a byte offset within a point, with one datatype code (PCL's
// PCLPointField and ROS's PointField share the codes 1..8).
//
//   PackedPoints packed;
//   packed.data = blob.data.data(); packed.size = blob.data.size();
//   packed.width = blob.width; packed.height = blob.height;
//   packed.point_step = blob.point_step; packed.row_step = blob.row_step;
//   packed.fields = {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}};
//   std::vector<Eigen::Vector3f> xyz = DecodeXyz(packed, "cloud.pcd");
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace furn {

// Datatype codes of PCL's PCLPointField and ROS's sensor_msgs/PointField.
enum class PointFieldType : uint8_t {
  kInt8 = 1,
  kUint8 = 2,
  kInt16 = 3,
  kUint16 = 4,
  kInt32 = 5,
  kUint32 = 6,
  kFloat32 = 7,
  kFloat64 = 8,
};

// Bytes of one value of a datatype code; 0 for a code outside 1..8.
int PointFieldBytes(uint8_t datatype);

struct PointFieldInfo {
  std::string name;
  uint64_t offset = 0;   // bytes from the start of a point
  uint8_t datatype = 0;  // a PointFieldType code
};

struct PackedPoints {
  const uint8_t* data = nullptr;
  size_t size = 0;  // bytes at data
  uint64_t width = 0, height = 0;
  uint64_t point_step = 0;  // bytes per point
  uint64_t row_step = 0;    // bytes per row; 0: width x point_step (PCL's blobs)
  bool big_endian = false;
  std::vector<PointFieldInfo> fields;
};

// Limit on width x height, so that a damaged header cannot ask for a huge
// allocation and one cloud cannot cost more than a frame may (2^24, as a
// depth image's kMaxDepthPixels: 55 times a 640 x 480 frame, some 1 GB to
// detect in).
inline constexpr uint64_t kMaxPackedPoints = uint64_t{1} << 24;

// The layout of a PCL PCLPointCloud2 or a ROS sensor_msgs/PointCloud2 (the
// two name their members alike); `cloud` must outlive the result.
template <typename Cloud>
PackedPoints PackedPointsOf(const Cloud& cloud) {
  PackedPoints packed;
  packed.data = cloud.data.data();
  packed.size = cloud.data.size();
  packed.width = cloud.width;
  packed.height = cloud.height;
  packed.point_step = cloud.point_step;
  packed.row_step = cloud.row_step;
  packed.big_endian = cloud.is_bigendian;
  for (const auto& field : cloud.fields)
    packed.fields.push_back({field.name, field.offset, field.datatype});
  return packed;
}

// x, y, z of every point, in row order, as floats. Throws InputError naming
// `where` and the rule when a field is missing, of an unknown type, lies
// outside point_step, when the rows do not fit row_step or the data, when
// there are more than kMaxPackedPoints points, or for big-endian data.
std::vector<Eigen::Vector3f> DecodeXyz(const PackedPoints& points, const std::string& where);

}  // namespace furn
