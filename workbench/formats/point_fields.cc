#include "workbench/formats/point_fields.h"

#include <cstring>
#include <limits>

#include "core/error.h"

namespace furn {
namespace {

template <typename T>
double Load(const uint8_t* at) {
  T value;
  std::memcpy(&value, at, sizeof(T));
  return static_cast<double>(value);
}

double ValueAt(const uint8_t* at, uint8_t datatype) {
  switch (static_cast<PointFieldType>(datatype)) {
    case PointFieldType::kInt8:
      return Load<int8_t>(at);
    case PointFieldType::kUint8:
      return Load<uint8_t>(at);
    case PointFieldType::kInt16:
      return Load<int16_t>(at);
    case PointFieldType::kUint16:
      return Load<uint16_t>(at);
    case PointFieldType::kInt32:
      return Load<int32_t>(at);
    case PointFieldType::kUint32:
      return Load<uint32_t>(at);
    case PointFieldType::kFloat32:
      return Load<float>(at);
    case PointFieldType::kFloat64:
      return Load<double>(at);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// The x, y or z field, checked against the point's size.
const PointFieldInfo& AxisField(const PackedPoints& points, char axis, const std::string& where) {
  const PointFieldInfo* found = nullptr;
  for (const PointFieldInfo& field : points.fields) {
    if (field.name == std::string(1, axis)) found = &field;
  }
  Require(found != nullptr, where + ": the cloud has no x, y, z fields (no '" + axis + "')");
  const int bytes = PointFieldBytes(found->datatype);
  Require(bytes > 0,
          where + ": field " + found->name + " has datatype " + std::to_string(found->datatype) +
              ", not one of the numeric types 1..8");
  Require(found->offset <= points.point_step &&
              static_cast<uint64_t>(bytes) <= points.point_step - found->offset,
          where + ": field " + found->name + " at offset " + std::to_string(found->offset) +
              " lies outside point_step " + std::to_string(points.point_step));
  return *found;
}

}  // namespace

int PointFieldBytes(uint8_t datatype) {
  switch (static_cast<PointFieldType>(datatype)) {
    case PointFieldType::kInt8:
    case PointFieldType::kUint8:
      return 1;
    case PointFieldType::kInt16:
    case PointFieldType::kUint16:
      return 2;
    case PointFieldType::kInt32:
    case PointFieldType::kUint32:
    case PointFieldType::kFloat32:
      return 4;
    case PointFieldType::kFloat64:
      return 8;
  }
  return 0;
}

std::vector<Eigen::Vector3f> DecodeXyz(const PackedPoints& points, const std::string& where) {
  Require(!points.big_endian, where + ": big-endian point clouds are not supported");
  const PointFieldInfo* fields[3] = {&AxisField(points, 'x', where),
                                     &AxisField(points, 'y', where),
                                     &AxisField(points, 'z', where)};
  const uint64_t width = points.width, height = points.height;
  Require(width <= kMaxPackedPoints && height <= kMaxPackedPoints &&
              width * height <= kMaxPackedPoints,
          where + ": " + std::to_string(width) + " x " + std::to_string(height) +
              " points is over the limit of 2^26");
  const uint64_t row_step = points.row_step > 0 ? points.row_step : width * points.point_step;
  Require(width * points.point_step <= row_step,
          where + ": row_step " + std::to_string(row_step) + " is less than width x point_step");
  Require(height == 0 || (row_step <= points.size / height),
          where + ": the cloud's data (" + std::to_string(points.size) +
              " bytes) is shorter than its header declares (height x row_step)");
  std::vector<Eigen::Vector3f> xyz;
  xyz.reserve(width * height);
  for (uint64_t r = 0; r < height; ++r) {
    for (uint64_t c = 0; c < width; ++c) {
      const uint8_t* point = points.data + r * row_step + c * points.point_step;
      Eigen::Vector3f p;
      for (int k = 0; k < 3; ++k) {
        p[k] = static_cast<float>(ValueAt(point + fields[k]->offset, fields[k]->datatype));
      }
      xyz.push_back(p);
    }
  }
  return xyz;
}

}  // namespace furn
