#include "workbench/formats/point_cloud_file.h"

#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "workbench/formats/point_fields.h"

namespace furn {

namespace {

// The whitespace-separated words of a header line.
std::vector<std::string> Words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

// A whole non-negative number of at most `limit`, or nullopt.
std::optional<uint64_t> Count(const std::string& word, uint64_t limit) {
  if (word.empty() || word.size() > 19 ||  // 19 digits always fit 64 bits
      !std::all_of(word.begin(), word.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  const unsigned long long value = std::stoull(word);
  if (value > limit) return std::nullopt;
  return value;
}

}  // namespace

namespace {

using PcdHeader = std::map<std::string, std::vector<std::string>>;

// The header's keyword lines up to DATA; `body_at` gets the body's offset
// and `data_kind` DATA's word.
PcdHeader ReadPcdHeader(const std::string& bytes,
                        const std::string& path,
                        size_t* body_at,
                        std::string* data_kind) {
  PcdHeader header;
  size_t at = 0;
  while (at < bytes.size() && data_kind->empty()) {
    const size_t end = bytes.find('\n', at);
    Require(end != std::string::npos && end - at < 65536,
            path + ": not a PCD file (its header ends without a DATA line)");
    const std::vector<std::string> words = Words(bytes.substr(at, end - at));
    at = end + 1;
    if (words.empty() || words[0][0] == '#') continue;
    static const std::set<std::string> kKeywords{
        "VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS"};
    if (words[0] == "DATA") {
      Require(words.size() == 2, path + ": PCD DATA must be ascii, binary or binary_compressed");
      *data_kind = words[1];
    } else {
      // PCL's reader misplaces the body after a line it does not know.
      Require(kKeywords.count(words[0]) > 0,
              path + ": not a PCD file (header line '" + words[0].substr(0, 40) +
                  "' is neither a comment nor a PCD keyword)");
      // PCL acts on every line as it comes (a POINTS line resizes the body):
      // a repeated keyword would be checked here only in its last form.
      Require(header.count(words[0]) == 0,
              path + ": PCD header line " + words[0] + " appears twice");
      header[words[0]] = std::vector<std::string>(words.begin() + 1, words.end());
    }
  }
  *body_at = at;
  return header;
}

// Bytes per point from SIZE, TYPE and COUNT, each entry checked.
uint64_t PcdPointStep(PcdHeader& header, const std::string& path) {
  const size_t fields = header["FIELDS"].size();
  Require(fields >= 1 && fields <= 1024, path + ": PCD FIELDS must name 1 to 1024 fields");
  std::vector<std::string> counts =
      header.count("COUNT") ? header["COUNT"] : std::vector<std::string>(fields, "1");
  Require(
      header["SIZE"].size() == fields && header["TYPE"].size() == fields && counts.size() == fields,
      path + ": PCD SIZE, TYPE and COUNT must have one entry per field (" + std::to_string(fields) +
          ")");
  uint64_t point_step = 0;
  for (size_t f = 0; f < fields; ++f) {
    const std::optional<uint64_t> size = Count(header["SIZE"][f], 8);
    const std::string& type = header["TYPE"][f];
    Require(size && (*size == 1 || *size == 2 || *size == 4 || *size == 8),
            path + ": PCD SIZE of field " + header["FIELDS"][f] + " must be 1, 2, 4 or 8");
    Require(type == "I" || type == "U" || (type == "F" && *size >= 4),
            path + ": PCD TYPE of field " + header["FIELDS"][f] +
                " must be I, U or F (F of size 4 or 8)");
    const std::optional<uint64_t> count = Count(counts[f], 4096);
    Require(count && *count >= 1,
            path + ": PCD COUNT of field " + header["FIELDS"][f] + " '" + counts[f] +
                "' must be in 1..4096");
    point_step += *size * *count;
  }
  return point_step;
}

// The body must hold what the header declares: nothing is allocated for
// points the file does not have.
void CheckPcdBody(const std::string& bytes,
                  size_t at,
                  const std::string& data_kind,
                  uint64_t points,
                  uint64_t point_step,
                  const std::string& path) {
  const uint64_t body = bytes.size() - at;
  const uint64_t needed = points * point_step;
  if (data_kind == "binary") {
    Require(needed <= body,
            path + ": PCD declares " + std::to_string(points) + " points of " +
                std::to_string(point_step) + " bytes, but its body has " + std::to_string(body) +
                " bytes");
  } else if (data_kind == "binary_compressed") {
    Require(body >= 8, path + ": PCD binary_compressed body lacks its two sizes");
    uint32_t compressed = 0, uncompressed = 0;
    std::memcpy(&compressed, bytes.data() + at, 4);
    std::memcpy(&uncompressed, bytes.data() + at + 4, 4);
    Require(compressed <= body - 8,
            path + ": PCD compressed size " + std::to_string(compressed) +
                " exceeds the file's body (" + std::to_string(body - 8) + " bytes)");
    Require(uncompressed == needed && (needed == 0 || compressed > 0),
            path + ": PCD uncompressed size " + std::to_string(uncompressed) +
                " must be POINTS x point size (" + std::to_string(needed) + ")");
    // LZF expands a byte of input into at most a few hundred bytes.
    Require(uncompressed <= 300ull * compressed + 1024,
            path + ": PCD compression ratio " + std::to_string(uncompressed) + " : " +
                std::to_string(compressed) + " is beyond LZF's");
  } else {
    const uint64_t lines = static_cast<uint64_t>(
        std::count(bytes.begin() + static_cast<std::ptrdiff_t>(at), bytes.end(), '\n') + 1);
    Require(points <= lines,
            path + ": PCD declares " + std::to_string(points) + " points, but its ascii body has " +
                std::to_string(lines) + " lines");
  }
}

}  // namespace

void CheckPcdHeader(const std::string& bytes, const std::string& path) {
  size_t at = 0;
  std::string data_kind;
  PcdHeader header = ReadPcdHeader(bytes, path, &at, &data_kind);
  Require(!data_kind.empty(), path + ": not a PCD file (its header ends without a DATA line)");
  for (const char* key : {"FIELDS", "SIZE", "TYPE", "WIDTH", "HEIGHT", "POINTS"}) {
    Require(header.count(key), path + ": not a PCD file (its header lacks " + key + ")");
  }
  Require(data_kind == "ascii" || data_kind == "binary" || data_kind == "binary_compressed",
          path + ": PCD DATA '" + data_kind + "' must be ascii, binary or binary_compressed");
  const uint64_t point_step = PcdPointStep(header, path);
  const std::optional<uint64_t> width =
      Count(header["WIDTH"].empty() ? "" : header["WIDTH"][0], 1u << 30);
  const std::optional<uint64_t> height =
      Count(header["HEIGHT"].empty() ? "" : header["HEIGHT"][0], 1u << 30);
  const std::optional<uint64_t> points =
      Count(header["POINTS"].empty() ? "" : header["POINTS"][0], 1u << 30);
  Require(width && height && points,
          path + ": PCD WIDTH, HEIGHT and POINTS must be whole numbers up to 2^30");
  Require(*width * *height == *points,
          path + ": PCD WIDTH x HEIGHT (" + std::to_string(*width) + " x " +
              std::to_string(*height) + ") must equal POINTS (" + std::to_string(*points) + ")");
  CheckPcdBody(bytes, at, data_kind, *points, point_step, path);
}

void CheckPlyHeader(const std::string& bytes, const std::string& path) {
  Require(bytes.rfind("ply", 0) == 0, path + ": not a PLY file (no 'ply' magic line)");
  const size_t end_header = bytes.find("end_header");
  Require(end_header != std::string::npos && end_header < (1u << 20),
          path + ": not a PLY file (no end_header)");
  std::istringstream in(bytes.substr(0, end_header));
  std::string line, format, element;
  struct Element {
    std::string name;
    uint64_t count = 0;
    uint64_t min_bytes = 0;  // of one record in a binary body
  };
  std::vector<Element> elements;
  auto scalar_size = [](const std::string& type) -> int {
    if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
    if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
    if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" ||
        type == "float32")
      return 4;
    if (type == "double" || type == "float64") return 8;
    return 0;
  };
  bool has_xyz[3] = {false, false, false};
  while (std::getline(in, line)) {
    const std::vector<std::string> words = Words(line);
    if (words.empty()) continue;
    static const std::set<std::string> kKeywords{
        "ply", "format", "comment", "obj_info", "element", "property", "end_header"};
    Require(kKeywords.count(words[0]) > 0,
            path + ": not a PLY file (header line '" + words[0].substr(0, 40) +
                "' is not a PLY keyword)");
    if (words[0] == "format" && words.size() >= 2) format = words[1];
    if (words[0] == "element") {
      const std::optional<uint64_t> count =
          words.size() == 3 ? Count(words[2], 1u << 30) : std::nullopt;
      Require(count.has_value(),
              path + ": PLY '" + line + "' must be 'element <name> <count up to 2^30>'");
      elements.push_back({words[1], *count, 0});
    }
    if (words[0] == "property") {
      Require(!elements.empty(), path + ": PLY property before any element");
      Element& e = elements.back();
      if (words.size() >= 2 && words[1] == "list") {
        Require(words.size() == 5 && scalar_size(words[2]) > 0 && scalar_size(words[3]) > 0,
                path + ": PLY '" + line + "' must be 'property list <type> <type> <name>'");
        // PCL's reader asserts on any list property of the vertex element.
        Require(e.name != "vertex",
                path + ": PLY vertex property " + words[4] + " must be a scalar, not a list");
        e.min_bytes += static_cast<uint64_t>(scalar_size(words[2]));
      } else {
        Require(words.size() == 3 && scalar_size(words[1]) > 0,
                path + ": PLY '" + line + "' must be 'property <type> <name>'");
        e.min_bytes += static_cast<uint64_t>(scalar_size(words[1]));
        for (int k = 0; k < 3; ++k) {
          if (e.name == "vertex" && words[2] == std::string(1, "xyz"[k])) has_xyz[k] = true;
        }
      }
    }
  }
  Require(format == "ascii" || format == "binary_little_endian" || format == "binary_big_endian",
          path + ": PLY format '" + format + "' must be ascii or binary_little/big_endian");
  Require(has_xyz[0] && has_xyz[1] && has_xyz[2],
          path + ": the cloud has no x, y, z fields (PLY vertex properties)");
  const uint64_t body = bytes.size() - std::min(bytes.size(), end_header + 11);
  uint64_t needed = 0;
  for (const Element& e : elements) {
    needed +=
        format == "ascii" ? e.count * 2 : e.count * e.min_bytes;  // ascii: a digit and a space
  }
  Require(needed <= body,
          path + ": PLY elements declare at least " + std::to_string(needed) +
              " bytes, but its body has " + std::to_string(body));
}

ScanCloud ReadPointCloudFile(const std::string& path) {
  const std::string extension = FileExtension(path);
  Require(extension == "pcd" || extension == "ply",
          path + ": point clouds are read from .pcd or .ply files");
  const std::string bytes = ReadFileBytes(path);  // a clear error for a missing file
  // PCL 1.13's PCD reader crashes on some malformed headers, so the header
  // is checked here first: PLY's magic line, or every PCD header field.
  if (extension == "ply") {
    CheckPlyHeader(bytes, path);
  } else {
    CheckPcdHeader(bytes, path);
  }
  pcl::PCLPointCloud2 blob;
  // PCL prints its own reasons; ours below is the one line the user sees.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  Eigen::Vector4f origin = Eigen::Vector4f::Zero();
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
  const int status = extension == "pcd" ? pcl::io::loadPCDFile(path, blob, origin, orientation)
                                        : pcl::io::loadPLYFile(path, blob);
  Require(status >= 0, path + ": not a readable " + extension + " point cloud");
  // x, y, z of any numeric type (float, double, integers), read as PCL laid
  // them out: fields at their offsets within each point_step-long point.
  ScanCloud scan;
  scan.points = DecodeXyz(PackedPointsOf(blob), path);
  if (blob.height > 1) {
    scan.width = static_cast<int>(blob.width);
    scan.height = static_cast<int>(blob.height);
  }
  // PCL fills the default viewpoint (origin, identity) when the header has
  // none; any other is the sensor's pose in the cloud's frame.
  if (!origin.head<3>().isZero() ||
      !orientation.coeffs().isApprox(Eigen::Quaternionf::Identity().coeffs())) {
    Require(origin.head<3>().allFinite() && orientation.coeffs().allFinite() &&
                std::abs(orientation.norm() - 1) < 1e-3,
            path + ": VIEWPOINT must be x y z qw qx qy qz with a unit quaternion");
    // A room's scans lie within metres of each other; a sensor 100 km away
    // is a broken pose, not a scan to fuse (its points would be dropped).
    Require(origin.head<3>().cwiseAbs().maxCoeff() <= 1e5,
            path + ": VIEWPOINT x y z must be within 100 km of the origin");
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = orientation.cast<double>().normalized().toRotationMatrix();
    pose.translation() = origin.head<3>().cast<double>();
    scan.viewpoint = pose;
  }
  return scan;
}

void WriteOrganizedPcd(const DepthFrame& frame,
                       const CameraIntrinsics& camera,
                       const std::string& path,
                       const std::optional<Eigen::Isometry3d>& world_from_camera) {
  Require(FileExtension(path) == "pcd", path + ": point clouds are written as .pcd");
  Require(frame.width == camera.width && frame.height == camera.height,
          path + ": frame size does not match the camera");
  const size_t pixels = static_cast<size_t>(frame.width) * frame.height;
  const bool labelled = frame.instance_ids.size() == pixels;
  pcl::PointCloud<pcl::PointXYZL> cloud(frame.width, frame.height);
  cloud.is_dense = false;
  const Eigen::Isometry3f world_from_camera_f =
      world_from_camera.value_or(Eigen::Isometry3d::Identity()).cast<float>();
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const float z = frame.DepthAt(u, v);
      pcl::PointXYZL& point = cloud.at(u, v);
      point.label = labelled ? frame.instance_ids[static_cast<size_t>(v) * frame.width + u] : 0;
      if (z <= 0) {
        point.x = point.y = point.z = std::numeric_limits<float>::quiet_NaN();
        continue;
      }
      const Eigen::Vector3f p = world_from_camera_f * (z * camera.RayThroughPixel(u, v));
      point.x = p.x();
      point.y = p.y();
      point.z = p.z();
    }
  }
  if (world_from_camera) {
    cloud.sensor_origin_ << world_from_camera->translation().cast<float>(), 0;
    cloud.sensor_orientation_ = Eigen::Quaternionf(world_from_camera->linear().cast<float>());
  }
  AtomicFile file(path);
  int saved = 0;
  if (labelled) {
    saved = pcl::io::savePCDFileBinary(file.TempPath(), cloud);
  } else {  // no ids: no label field (the pose stays)
    pcl::PointCloud<pcl::PointXYZ> unlabelled;
    pcl::copyPointCloud(cloud, unlabelled);
    saved = pcl::io::savePCDFileBinary(file.TempPath(), unlabelled);
  }
  Require(saved == 0, path + ": cannot write PCD");
  file.Commit();
}

}  // namespace furn
