#include "workbench/formats/real_labels.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "core/geometry/conventions.h"
#include "core/util/angles.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "workbench/formats/camera_file.h"

namespace furn {
namespace {

constexpr char kFormat[] = "furnidet-real-set";

// Reads a JSON value of the expected kind, naming the field on failure.
class Fields {
 public:
  Fields(const nlohmann::json& object, std::string where, const std::set<std::string>& known)
      : object_(object), where_(std::move(where)) {
    Require(object.is_object(), where_ + " must be a JSON object");
    for (const auto& [key, value] : object.items()) {
      Require(known.count(key) > 0, where_ + ": unknown key '" + key + "'");
    }
  }
  bool Has(const std::string& key) const {
    return object_.contains(key) && !object_.at(key).is_null();
  }
  std::string Text(const std::string& key, const std::string& fallback = "") const {
    if (!Has(key)) return fallback;
    Require(object_.at(key).is_string(), where_ + ": '" + key + "' must be a string");
    return object_.at(key).get<std::string>();
  }
  double Number(const std::string& key, double fallback) const {
    if (!Has(key)) return fallback;
    const nlohmann::json& value = object_.at(key);
    Require(value.is_number() && std::isfinite(value.get<double>()),
            where_ + ": '" + key + "' must be a finite number");
    return value.get<double>();
  }
  bool Flag(const std::string& key) const {
    if (!Has(key)) return false;
    Require(object_.at(key).is_boolean(), where_ + ": '" + key + "' must be true or false");
    return object_.at(key).get<bool>();
  }
  std::vector<double> Numbers(const std::string& key, size_t count) const {
    const nlohmann::json& value = object_.at(key);
    Require(value.is_array() && value.size() == count,
            where_ + ": '" + key + "' must be an array of " + std::to_string(count) + " numbers");
    std::vector<double> numbers;
    for (const nlohmann::json& v : value) {
      Require(v.is_number() && std::isfinite(v.get<double>()),
              where_ + ": '" + key + "' must hold finite numbers");
      numbers.push_back(v.get<double>());
    }
    return numbers;
  }
  const std::string& where() const { return where_; }

 private:
  const nlohmann::json& object_;
  std::string where_;
};

// Version 1 labels give the CAD model's yaw (front -y) and size [width,
// depth, height]; version 2 REP 103 boxes (docs/conventions.md): the yaw of
// the front and size [along the front, across, height].
RealObject ReadObject(const nlohmann::json& json, const std::string& where, int version) {
  const Fields fields(json, where, {"class", "x", "y", "yaw", "size", "visibility", "note"});
  RealObject object;
  const std::string name = fields.Text("class");
  // Every class the detector knows (NYU's real rooms have sofas); other
  // names are refused with the list.
  const std::optional<FurnitureClass> furniture_class = FurnitureClassNamed(name);
  Require(furniture_class.has_value(),
          where + ": class '" + name + "' must be chair, armchair, table, sideboard or sofa");
  object.furniture_class = *furniture_class;
  Require(fields.Has("x") && fields.Has("y"), where + ": needs 'x' and 'y' (metres)");
  object.x = fields.Number("x", 0);
  object.y = fields.Number("y", 0);
  if (fields.Has("yaw")) {
    object.yaw = fields.Number("yaw", 0);
    // Radians: beyond +-2 pi a value is degrees or a typo.
    Require(std::abs(*object.yaw) <= 2 * M_PI + 1e-9,
            where + ": 'yaw' " + std::to_string(*object.yaw) + " must be radians in -2 pi..2 pi");
    if (version >= 2) object.yaw = WrapAngle(ModelYawFromRep103Yaw(*object.yaw));
  }
  if (fields.Has("size")) {
    const std::vector<double> size = fields.Numbers("size", 3);
    Require(
        size[0] > 0 && size[1] > 0 && size[2] > 0 && size[0] < 10 && size[1] < 10 && size[2] < 10,
        where +
            (version >= 2 ? ": 'size' [along the front, across, height]"
                          : ": 'size' [width, depth, height]") +
            " must be in (0, 10) metres");
    object.size = version >= 2 ? Eigen::Vector3d(size[1], size[0], size[2])
                               : Eigen::Vector3d(size[0], size[1], size[2]);
  }
  object.visibility = fields.Number("visibility", 1);
  Require(object.visibility >= 0 && object.visibility <= 1,
          where + ": 'visibility' must be in 0..1");
  object.note = fields.Text("note");
  return object;
}

Eigen::Isometry3d RigidFromRows(const std::vector<double>& m, const std::string& where) {
  Eigen::Matrix4d matrix;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) matrix(r, c) = m[4 * r + c];
  const Eigen::Matrix3d rotation = matrix.topLeftCorner<3, 3>();
  Require(
      (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-3 &&
          std::abs(rotation.determinant() - 1) < 1e-3 &&
          matrix.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)),
      where + ": 'label_frame' must be a rigid motion (rotation, translation, last row 0 0 0 1)");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = matrix.topRightCorner<3, 1>();
  return pose;
}

RealScan ReadScan(const nlohmann::json& json,
                  const std::filesystem::path& base,
                  const std::string& where,
                  int version) {
  const Fields fields(json,
                      where,
                      {"id",
                       "cloud",
                       "depth",
                       "intrinsics",
                       "camera",
                       "depth_scale",
                       "world_from_camera",
                       "floor_aligned",
                       "sensor",
                       "source",
                       "licence",
                       "label_frame",
                       "objects",
                       "note"});
  RealScan scan;
  scan.id = fields.Text("id");
  Require(!scan.id.empty(), where + ": needs an 'id'");
  const std::string named = where + " ('" + scan.id + "')";
  auto resolve = [&](const std::string& relative) {
    const std::filesystem::path path = base / relative;
    std::error_code ec;
    Require(std::filesystem::exists(path, ec),
            named + ": file '" + path.string() + "' does not exist");
    Require(std::filesystem::is_regular_file(path, ec),
            named + ": '" + path.string() + "' is not a regular file (a device, FIFO or folder)");
    return path.lexically_normal().string();
  };
  Require(fields.Has("cloud") != fields.Has("depth"),
          named + ": give exactly one of 'cloud' or 'depth'");
  if (fields.Has("cloud")) scan.source.cloud_path = resolve(fields.Text("cloud"));
  if (fields.Has("depth")) scan.source.depth_path = resolve(fields.Text("depth"));
  scan.source.intrinsics = fields.Text("intrinsics", "kinect1");
  if (fields.Has("camera")) scan.source.camera_file = resolve(fields.Text("camera"));
  scan.source.depth_scale = fields.Number("depth_scale", 0);
  Require(scan.source.depth_scale >= 0, named + ": 'depth_scale' must be > 0");
  scan.source.world_from_camera = fields.Text("world_from_camera");
  if (!scan.source.world_from_camera.empty()) {  // checked here, named as the labels' field
    try {
      ParsePose(scan.source.world_from_camera, "'world_from_camera'");
    } catch (const InputError& error) {
      throw InputError(named + ": " + error.what());
    }
  }
  scan.source.floor_aligned = fields.Flag("floor_aligned");
  scan.source.sensor = fields.Text("sensor");
  scan.origin = fields.Text("source");
  scan.licence = fields.Text("licence");
  Require(!scan.origin.empty() && !scan.licence.empty(),
          named + ": needs 'source' and 'licence' (where the scan comes from, and its terms)");
  if (fields.Has("label_frame")) {
    Require(!scan.source.floor_aligned,
            named + ": a floor-aligned scan's labels are in its own frame; drop 'label_frame'");
    scan.label_frame = RigidFromRows(fields.Numbers("label_frame", 16), named);
  } else {
    Require(scan.source.floor_aligned,
            named +
                ": needs 'label_frame' (the camera's pose in the labels' floor frame, 16 "
                "numbers row by row), or 'floor_aligned': true");
  }
  Require(json.contains("objects") && json.at("objects").is_array(),
          named + ": needs 'objects' (an array, empty for a scan without furniture)");
  for (size_t k = 0; k < json.at("objects").size(); ++k) {
    scan.objects.push_back(
        ReadObject(json.at("objects")[k], named + " object " + std::to_string(k), version));
  }
  return scan;
}

}  // namespace

RealSet ReadRealSet(const std::string& path) {
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(ReadFileBytes(path));
  } catch (const nlohmann::json::exception& error) {
    throw InputError(path + ": not JSON: " + error.what());
  }
  const Fields top(json, path, {"format", "version", "scans", "note"});
  Require(top.Text("format") == kFormat, path + ": 'format' must be \"" + kFormat + "\"");
  Require(json.at("version").is_number_integer() &&
              (json.at("version").get<int>() == 1 || json.at("version").get<int>() == 2),
          path + ": 'version' must be 1 or 2 (2: REP 103 yaw and size, docs/conventions.md)");
  Require(json.contains("scans") && json.at("scans").is_array() && !json.at("scans").empty(),
          path + ": 'scans' must be a non-empty array");
  const int version = json.at("version").get<int>();
  RealSet set;
  set.path = path;
  const std::filesystem::path base = std::filesystem::path(path).parent_path();
  std::set<std::string> ids;
  for (size_t k = 0; k < json.at("scans").size(); ++k) {
    RealScan scan =
        ReadScan(json.at("scans")[k], base, path + ": scan " + std::to_string(k), version);
    Require(ids.insert(scan.id).second, path + ": scan id '" + scan.id + "' appears twice");
    set.scans.push_back(std::move(scan));
  }
  return set;
}

std::set<int64_t> FramesWithEstimatedPose(const std::string& generation_options_json) {
  std::set<int64_t> frames;
  const nlohmann::json json = nlohmann::json::parse(generation_options_json, nullptr, false);
  auto is = [](const nlohmann::json& object, const char* key, const char* text) {
    return object.is_object() && object.contains(key) && object[key].is_string() &&
           object[key].get<std::string>() == text;
  };
  if (!is(json, "kind", "real-set")) return frames;
  Require(json.contains("frames") && json["frames"].is_array(),
          "a real-set dataset's generation options lack their frames (a damaged file)");
  for (const nlohmann::json& frame : json["frames"]) {
    if (!is(frame, "pose", "estimate")) continue;
    Require(frame.contains("frame") && frame["frame"].is_number_integer(),
            "a real-set dataset's frame entry lacks its id (a damaged file)");
    frames.insert(frame["frame"].get<int64_t>());
  }
  return frames;
}

}  // namespace furn
