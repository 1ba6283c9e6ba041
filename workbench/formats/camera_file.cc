#include "workbench/formats/camera_file.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <vector>

#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {
namespace {

// A camera file is a few hundred bytes; a large one is not parsed at all
// (yaml-cpp took 2 GB for a 12 MB list).
constexpr size_t kMaxCameraFileBytes = 1 << 20;

// The 3x3 row-major matrix K as intrinsics, checking its zeros.
void SetFromMatrix(const std::vector<double>& k,
                   const std::string& where,
                   CameraIntrinsics* camera) {
  const CameraIntrinsics from_k = CameraFromMatrix(k, 0, 0, where);
  camera->fx = from_k.fx;
  camera->cx = from_k.cx;
  camera->fy = from_k.fy;
  camera->cy = from_k.cy;
}

// An image size from a file: a whole number in 1..16384.
int ImageSize(double value, const std::string& where) {
  Require(std::isfinite(value) && value >= 1 && value <= 16384 && value == std::floor(value),
          where + " must be a whole number in 1..16384");
  return static_cast<int>(value);
}

CameraFile FromJson(const nlohmann::json& json,
                    const std::string& path,
                    std::optional<int64_t> image_id) {
  CameraFile file;
  file.camera.width = file.camera.height = 0;
  auto number = [&](const nlohmann::json& object, const char* key, const std::string& where) {
    Require(object.contains(key) && object[key].is_number(),
            path + ": " + where + "'" + key + "' must be a number");
    return object[key].get<double>();
  };
  const bool camera_json = json.contains("fx") || json.contains("fy") || json.contains("cx") ||
                           json.contains("cy") || json.contains("width") || json.contains("height");
  if (camera_json) {  // BOP camera.json
    file.camera.fx = number(json, "fx", "");
    file.camera.fy = number(json, "fy", "");
    file.camera.cx = number(json, "cx", "");
    file.camera.cy = number(json, "cy", "");
    if (json.contains("width"))
      file.camera.width = ImageSize(number(json, "width", ""), path + ": 'width'");
    if (json.contains("height"))
      file.camera.height = ImageSize(number(json, "height", ""), path + ": 'height'");
    if (json.contains("depth_scale")) file.units_per_metre = 1000 / number(json, "depth_scale", "");
  } else {  // BOP scene_camera.json
    Require(image_id.has_value(),
            path + ": a BOP scene_camera.json needs the image id (from the depth file's name)");
    const std::string key = std::to_string(*image_id);
    Require(json.contains(key) && json[key].is_object(),
            path + ": no camera for image " + key +
                " (neither camera.json keys fx.. nor a "
                "scene_camera.json entry)");
    const nlohmann::json& entry = json[key];
    Require(entry.contains("cam_K") && entry["cam_K"].is_array(),
            path + ": image " + key + " has no cam_K array");
    std::vector<double> k;
    for (const nlohmann::json& v : entry["cam_K"]) {
      Require(v.is_number(), path + ": image " + key + " cam_K holds a non-number");
      k.push_back(v.get<double>());
    }
    SetFromMatrix(k, path + ": image " + key + " cam_K", &file.camera);
    if (entry.contains("depth_scale"))
      file.units_per_metre = 1000 / number(entry, "depth_scale", "image " + key + " ");
  }
  if (file.units_per_metre) CheckUnitsPerMetre(*file.units_per_metre, path + ": depth_scale");
  return file;
}

CameraFile FromYaml(const YAML::Node& root, const std::string& path) {
  CameraFile file;
  file.camera.width = file.camera.height = 0;
  Require(root.IsMap(), path + ": not a camera file (YAML without keys)");
  auto integer = [&](const char* key) {
    double value = 0;
    try {
      value = root[key].as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(path + ": '" + std::string(key) + "' must be an integer");
    }
    return ImageSize(value, path + ": '" + key + "'");
  };
  auto numbers = [&](const YAML::Node& node, const std::string& where) {
    std::vector<double> values;
    try {
      for (const YAML::Node& v : node) values.push_back(v.as<double>());
    } catch (const YAML::Exception&) {
      throw InputError(path + ": " + where + " must be a list of numbers");
    }
    return values;
  };
  if (root["camera_matrix"]) {  // camera_calibration's file
    Require(root["camera_matrix"].IsMap() && root["camera_matrix"]["data"].IsSequence(),
            path + ": camera_matrix has no data list");
    SetFromMatrix(numbers(root["camera_matrix"]["data"], "camera_matrix.data"),
                  path + ": camera_matrix.data",
                  &file.camera);
    if (root["image_width"]) file.camera.width = integer("image_width");
    if (root["image_height"]) file.camera.height = integer("image_height");
    return file;
  }
  const char* k_key = root["K"] ? "K" : (root["k"] ? "k" : nullptr);
  Require(k_key != nullptr,
          path +
              ": not a camera file (no fx, cam_K, camera_matrix, K or k: see README, "
              "'Real scans')");
  SetFromMatrix(numbers(root[k_key], k_key), path + ": " + k_key, &file.camera);
  if (root["width"]) file.camera.width = integer("width");
  if (root["height"]) file.camera.height = integer("height");
  return file;
}

// The text of a YAML stream's first document: up to a line '---' or '...'
// that follows some content.
std::string FirstYamlDocument(const std::string& text) {
  size_t at = 0;
  bool content = false;
  while (at < text.size()) {
    size_t end = text.find('\n', at);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(at, end - at);
    const bool marker = line.rfind("---", 0) == 0 || line.rfind("...", 0) == 0;
    if (marker && content) return text.substr(0, at);
    content |= !marker && line.find_first_not_of(" \t\r") != std::string::npos;
    at = end + 1;
  }
  return text;
}

std::vector<double> Numbers(const std::string& text, const std::string& what) {
  std::string spaced = text;
  for (char& c : spaced) {
    if (c == ',') c = ' ';
  }
  std::istringstream stream(spaced);
  std::vector<double> values;
  std::string item;
  while (stream >> item) {
    try {
      size_t used = 0;
      values.push_back(std::stod(item, &used));
      Require(used == item.size() && std::isfinite(values.back()), "");
    } catch (const std::exception&) {
      throw InputError(what + " '" + text + "': '" + item + "' is not a finite number");
    }
  }
  return values;
}

}  // namespace

CameraIntrinsics CameraFromMatrix(const std::vector<double>& k,
                                  int width,
                                  int height,
                                  const std::string& where) {
  Require(k.size() == 9,
          where + " must hold 9 numbers (a 3x3 matrix), it holds " + std::to_string(k.size()));
  Require(k[1] == 0 && k[3] == 0 && k[6] == 0 && k[7] == 0 && k[8] == 1,
          where + " must be [fx, 0, cx, 0, fy, cy, 0, 0, 1] (no skew)");
  CameraIntrinsics camera{width, height, k[0], k[4], k[2], k[5]};
  if (width > 0 && height > 0) {
    try {
      camera.Check();
    } catch (const InputError& e) {
      throw InputError(where + ": " + e.what());
    }
  }
  return camera;
}

void CheckUnitsPerMetre(double units_per_metre, const std::string& what) {
  char text[128];
  std::snprintf(text,
                sizeof(text),
                " gives %g depth units per metre, not in 1..1000000 (1: metres, 1000: mm)",
                units_per_metre);
  Require(std::isfinite(units_per_metre) && units_per_metre >= 1 && units_per_metre <= 1e6,
          what + text);
}

CameraFile ReadCameraFile(const std::string& path, std::optional<int64_t> image_id) {
  RequireRegularFile(path);
  std::error_code error;
  const uintmax_t bytes = std::filesystem::file_size(path, error);
  Require(error || bytes <= kMaxCameraFileBytes,
          path + ": a camera file of " + std::to_string(bytes) +
              " bytes (a camera file is at most 1 MiB)");
  const std::string text = ReadFileBytes(path);
  CameraFile file;
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    nlohmann::json json;
    try {
      json = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path + ": not valid JSON (" + std::string(e.what()) + ")");
    }
    file = FromJson(json, path, image_id);
  } else {
    YAML::Node root;
    try {
      // A message dump from rostopic echo ends its document with '---'; only
      // the first document is parsed, with Load: yaml-cpp 0.7's LoadAll loops
      // forever on a document that starts with ',' (yaml-cpp issue #1040).
      root = YAML::Load(FirstYamlDocument(text));
    } catch (const YAML::Exception& e) {
      throw InputError(path + ": not a JSON or YAML camera file (" + e.msg + ")");
    }
    try {
      file = FromYaml(root, path);
    } catch (const YAML::Exception& e) {  // a key of the wrong kind (a scalar for a map)
      throw InputError(path + ": not a camera file (" + e.msg + ")");
    }
  }
  const bool sized = file.camera.width > 0 || file.camera.height > 0;
  CameraIntrinsics check = file.camera;
  if (!sized) {  // the principal point is checked against the image later
    check.width = static_cast<int>(std::ceil(std::max(1.0, 2 * check.cx + 1)));
    check.height = static_cast<int>(std::ceil(std::max(1.0, 2 * check.cy + 1)));
  }
  try {
    check.Check();
  } catch (const InputError& e) {
    throw InputError(path + ": " + e.what());
  }
  return file;
}

namespace {

constexpr const char* kPoseForms =
    "16 numbers (a 4x4 matrix, row by row) or 't=x,y,z q=qx,qy,qz,qw' (the quaternion x,y,z,w "
    "as ROS messages and Eigen's coeffs() write it)";

// "t=x,y,z q=qx,qy,qz,qw": parts apart by spaces or ';', in either order.
Eigen::Isometry3d LabelledPose(const std::string& text, const std::string& what) {
  std::string spaced = text;
  for (char& c : spaced) {
    if (c == ';') c = ' ';
  }
  std::istringstream parts(spaced);
  std::optional<std::vector<double>> t, q;
  std::string part;
  while (parts >> part) {
    const size_t equals = part.find('=');
    const std::string key = part.substr(0, equals);
    std::optional<std::vector<double>>* slot = key == "t" ? &t : key == "q" ? &q : nullptr;
    Require(equals != std::string::npos && slot != nullptr && !slot->has_value(),
            what + " '" + text + "': '" + part + "' is not one t=... or q=...; give " + kPoseForms);
    *slot = Numbers(part.substr(equals + 1), what);
  }
  Require(t && q && t->size() == 3 && q->size() == 4,
          what + " '" + text + "' needs t= with 3 numbers and q= with 4; give " + kPoseForms);
  const Eigen::Quaterniond rotation((*q)[3], (*q)[0], (*q)[1], (*q)[2]);  // w first in Eigen
  Require(std::abs(rotation.norm() - 1) < 1e-3,
          what + " '" + text + "': the quaternion qx,qy,qz,qw must have unit length (it has " +
              std::to_string(rotation.norm()) + ")");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation.normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d((*t)[0], (*t)[1], (*t)[2]);
  return pose;
}

}  // namespace

Eigen::Isometry3d ParsePose(const std::string& text, const std::string& what) {
  if (text.find('=') != std::string::npos) return LabelledPose(text, what);
  const std::vector<double> v = Numbers(text, what);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  // Seven bare numbers were once x,y,z,qw,qx,qy,qz: read in either order
  // they would move a pasted pose silently, so they are refused.
  Require(v.size() != 7,
          what + " '" + text +
              "': seven bare numbers are not read (they were once x,y,z,qw,qx,qy,qz); give " +
              kPoseForms);
  Require(v.size() == 16,
          what + " '" + text + "' must be " + kPoseForms + "; it has " + std::to_string(v.size()) +
              " numbers");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = v[4 * r + c];
  }
  const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
  Require(m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)) &&
              (rotation * rotation.transpose()).isApprox(Eigen::Matrix3d::Identity(), 1e-4) &&
              rotation.determinant() > 0,
          what + " '" + text +
              "' is not a rigid transform (rotation and translation, last "
              "row 0 0 0 1)");
  pose.linear() = rotation;
  pose.translation() = m.topRightCorner<3, 1>();
  return pose;
}

Eigen::Vector3d ParsePosition(const std::string& text, const std::string& what) {
  const std::vector<double> v = Numbers(text, what);
  Require(v.size() == 3, what + " '" + text + "' must be x,y,z (three numbers)");
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

}  // namespace furn
