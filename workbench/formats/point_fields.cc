#include "workbench/formats/point_fields.h"

#include <cstring>
#include <iterator>
#include <limits>

#include "core/util/error.h"

namespace furn {
namespace {

template <typename T>
double Load(const uint8_t* at) {
  T value;
  std::memcpy(&value, at, sizeof(T));
  return static_cast<double>(value);
}

// The value of a field of type `datatype` (a code 1..8, checked by
// AxisField) at `at`; by code: int8, uint8, int16, uint16, int32, uint32,
// float32, float64.
double ValueAt(const uint8_t* at, uint8_t datatype) {
  using Loader = double (*)(const uint8_t*);
  constexpr Loader kLoaders[] = {nullptr,
                                 &Load<int8_t>,
                                 &Load<uint8_t>,
                                 &Load<int16_t>,
                                 &Load<uint16_t>,
                                 &Load<int32_t>,
                                 &Load<uint32_t>,
                                 &Load<float>,
                                 &Load<double>};
  return datatype >= 1 && datatype < std::size(kLoaders) ? kLoaders[datatype](at)
                                                         : std::numeric_limits<double>::quiet_NaN();
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
  // By code: int8, uint8, int16, uint16, int32, uint32, float32, float64.
  constexpr int kBytes[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
  return datatype < std::size(kBytes) ? kBytes[datatype] : 0;
}

std::vector<Eigen::Vector3f> DecodeXyz(const PackedPoints& points, const std::string& where) {
  Require(!points.big_endian, where + ": big-endian point clouds are not supported");
  const PointFieldInfo* fields[3] = {&AxisField(points, 'x', where),
                                     &AxisField(points, 'y', where),
                                     &AxisField(points, 'z', where)};
  const uint64_t width = points.width, height = points.height;
  Require(
      width <= kMaxPackedPoints && height <= kMaxPackedPoints && width * height <= kMaxPackedPoints,
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
