#include "workbench/formats/external_detections.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/geometry/mesh.h"          // ContentHasher
#include "core/learned/bev_box_coder.h"  // BevYawSymmetry
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "workbench/formats/json_text.h"

namespace furn {

ScoredDetection ScoredDetectionOfBox(FurnitureClass furniture_class,
                                     double score,
                                     const OrientedBox& box) {
  ScoredDetection d;
  d.x = box.centre.x();
  d.y = box.centre.y();
  d.yaw = ModelYawFromRep103Yaw(box.yaw);
  d.width = box.size.y();  // across the front
  d.depth = box.size.x();  // front to back
  d.furniture_class = furniture_class;
  d.score = score;
  d.symmetry = BevYawSymmetry(furniture_class);
  d.box3d = box;
  return d;
}

namespace {

using Json = nlohmann::ordered_json;

// The checks of one line's fields; every message names the file and line
// ("dets.jsonl:12"), the field and the rule.
class LineReader {
 public:
  explicit LineReader(std::string where) : where_(std::move(where)) {}

  const std::string& where() const { return where_; }

  [[noreturn]] void Fail(const std::string& field, const std::string& rule) const {
    throw InputError(where_ + ": \"" + field + "\" " + rule);
  }

  const Json& Member(const Json& object, const std::string& key, const std::string& field) const {
    const auto found = object.find(key);
    if (found == object.end()) Fail(field, "is missing");
    return *found;
  }

  double Number(const Json& value, const std::string& field) const {
    if (!value.is_number()) Fail(field, "must be a number");
    const double number = value.get<double>();
    if (!std::isfinite(number)) Fail(field, "must be finite");
    return number;
  }

  double NumberAt(const Json& object, const std::string& key, const std::string& field) const {
    return Number(Member(object, key, field), field);
  }

  Eigen::VectorXd Numbers(const Json& object,
                          const std::string& key,
                          int count,
                          const std::string& field) const {
    const Json& value = Member(object, key, field);
    if (!value.is_array() || static_cast<int>(value.size()) != count)
      Fail(field, "must be an array of " + std::to_string(count) + " numbers");
    Eigen::VectorXd numbers(count);
    for (int k = 0; k < count; ++k)
      numbers[k] = Number(value[k], field + "[" + std::to_string(k) + "]");
    return numbers;
  }

  FurnitureClass Class(const Json& object, const std::string& field) const {
    const Json& value = Member(object, "class", field);
    std::string classes;
    for (FurnitureClass c : kAllClasses)
      classes += std::string(classes.empty() ? "" : ", ") + ClassName(c);
    if (!value.is_string()) Fail(field, "must be a class name (" + classes + ")");
    const std::optional<FurnitureClass> parsed =
        TryParseEnum<FurnitureClass>(value.get<std::string>());
    if (!parsed)
      Fail(field, "is \"" + value.get<std::string>().substr(0, 40) + "\", not one of " + classes);
    return *parsed;
  }

  OrientedBox Box(const Json& detection, const std::string& field) const {
    OrientedBox box;
    box.centre = Numbers(detection, "centre", 3, field + ".centre");
    box.size = Numbers(detection, "size", 3, field + ".size");
    if ((box.size.array() < 0).any()) Fail(field + ".size", "must not be negative");
    box.yaw = WrapToPi(NumberAt(detection, "yaw", field + ".yaw"));
    return box;
  }

  // A detection of either format (detect's output always has the optional
  // "floor_point", "model" and "size_source").
  ScoredDetection Detection(const Json& detection, const std::string& field) const {
    if (!detection.is_object()) Fail(field, "must be an object");
    const FurnitureClass furniture_class = Class(detection, field + ".class");
    const double score = NumberAt(detection, "score", field + ".score");
    ScoredDetection d = ScoredDetectionOfBox(furniture_class, score, Box(detection, field));
    if (detection.contains("floor_point")) {
      const Eigen::VectorXd point = Numbers(detection, "floor_point", 2, field + ".floor_point");
      d.x = point[0];
      d.y = point[1];
    }
    if (detection.contains("symmetry")) {
      const Json& value = detection["symmetry"];
      if (!value.is_number_integer() ||
          (value.get<int64_t>() != 1 && value.get<int64_t>() != 2 && value.get<int64_t>() != 4))
        Fail(field + ".symmetry", "must be 1, 2 or 4");
      d.symmetry = value.get<int>();
    }
    if (detection.contains("model") && !detection["model"].is_null()) {
      if (!detection["model"].is_string()) Fail(field + ".model", "must be a string or null");
      d.model_id = detection["model"].get<std::string>();
    }
    if (detection.contains("size_source")) {
      const Json& value = detection["size_source"];
      const std::string source = value.is_string() ? value.get<std::string>() : "";
      if (source != "network" && source != "model" && source != "class")
        Fail(field + ".size_source", "must be \"network\", \"model\" or \"class\"");
      if (source != "network") d.width = d.depth = 0;  // not the detector's footprint estimate
    }
    return d;
  }

  std::vector<ScoredDetection> Detections(const Json& line) const {
    const Json& list = Member(line, "detections", "detections");
    if (!list.is_array()) Fail("detections", "must be an array (empty when nothing was found)");
    std::vector<ScoredDetection> detections;
    for (size_t k = 0; k < list.size(); ++k)
      detections.push_back(Detection(list[k], "detections[" + std::to_string(k) + "]"));
    return detections;
  }

  int64_t FrameId(const Json& line, const std::string& key) const {
    const Json& value = Member(line, key, key);
    if (!value.is_number_integer() || value.get<int64_t>() < 0)
      Fail(key, "must be a dataset frame id (an integer >= 0)");
    return value.get<int64_t>();
  }

  Eigen::Isometry3d Pose(const Json& line, const std::string& key) const {
    const Json& rows = Member(line, key, key);
    if (!rows.is_array() || rows.size() != 4) Fail(key, "must be 4 rows of 4 numbers");
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
      if (!rows[r].is_array() || rows[r].size() != 4) Fail(key, "must be 4 rows of 4 numbers");
      for (int c = 0; c < 4; ++c)
        m(r, c) =
            Number(rows[r][c], key + "[" + std::to_string(r) + "][" + std::to_string(c) + "]");
    }
    Eigen::Isometry3d pose;
    pose.matrix() = m;
    return pose;
  }

 private:
  std::string where_;
};

// One line of either format, as a frame's detections.
std::pair<int64_t, ExternalFrame> ReadLine(const Json& line,
                                           const LineReader& reader,
                                           std::string* detector) {
  if (!line.is_object()) reader.Fail("(line)", "must be a JSON object");
  const Json& format = reader.Member(line, "format", "format");
  ExternalFrame frame;
  frame.where = reader.where();
  int64_t id = 0;
  if (format.is_number_integer() && format.get<int64_t>() == 2) {  // detect --out
    if (line.contains("error"))
      reader.Fail("error", "says detection failed on this scan; rerun it or drop the line");
    if (!line.contains("dataset_frame"))
      reader.Fail("dataset_frame",
                  "is missing: only detect's output for a dataset frame (--db D --frame F) "
                  "names the frame it scored");
    id = reader.FrameId(line, "dataset_frame");
    if (line.value("floor_estimated", false))
      frame.detector_world_from_camera = reader.Pose(line, "world_from_camera");
    if (detector->empty() && line.contains("program") && line["program"].is_string())
      *detector = line["program"].get<std::string>();
  } else {
    if (!format.is_string() || format.get<std::string>() != kExternalDetectionsFormat)
      reader.Fail(
          "format",
          std::string("must be \"") + kExternalDetectionsFormat + "\" (or 2, detect's own output)");
    const Json& version = reader.Member(line, "version", "version");
    if (!version.is_number_integer() || version.get<int64_t>() < 1)
      reader.Fail("version", "must be an integer >= 1");
    if (version.get<int64_t>() > kExternalDetectionsVersion)
      reader.Fail("version",
                  "is " + std::to_string(version.get<int64_t>()) +
                      ": written for a newer workbench (this one reads version " +
                      std::to_string(kExternalDetectionsVersion) + ")");
    id = reader.FrameId(line, "frame");
    if (line.contains("time_ms")) {
      frame.time_ms = reader.NumberAt(line, "time_ms", "time_ms");
      if (*frame.time_ms < 0) reader.Fail("time_ms", "must not be negative");
    }
    if (line.contains("detector")) {
      if (!line["detector"].is_string()) reader.Fail("detector", "must be a string");
      if (detector->empty()) *detector = line["detector"].get<std::string>();
    }
  }
  frame.detections = reader.Detections(line);
  return {id, std::move(frame)};
}

// The frames of one file into `out`.
void ReadFile(const std::string& path, ExternalDetections* out, ContentHasher* hash) {
  const std::string text = ReadFileBytes(path);
  hash->Update(text.data(), text.size());
  out->files.push_back(path);
  // The lines; a file whose first line is not a whole object is one JSON
  // value (detect's indented output of one scan).
  std::vector<std::pair<int, std::string>> lines;
  size_t start = 0;
  for (int number = 1; start < text.size(); ++number) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    line.erase(0, line.find_first_not_of(" \t\r"));
    line.erase(line.find_last_not_of(" \t\r") + 1);
    if (!line.empty()) lines.emplace_back(number, std::move(line));
    start = end + 1;
  }
  Require(!lines.empty(), path + ": is empty (one JSON line per frame expected)");
  const std::string& first = lines.front().second;
  if (first.front() != '{' || first.back() != '}') lines = {{1, text}};
  for (const auto& [number, line] : lines) {
    const LineReader reader(path + ":" + std::to_string(number));
    auto [id, frame] = ReadLine(ParseUserJson(line, reader.where()), reader, &out->detector);
    const auto [at, inserted] = out->frames.emplace(id, std::move(frame));
    if (!inserted)
      throw InputError(reader.where() + ": \"frame\" " + std::to_string(id) +
                       " comes twice (first at " + at->second.where + ")");
  }
}

}  // namespace

ExternalDetections ReadExternalDetections(const std::string& path) {
  std::error_code ec;
  std::vector<std::string> files;
  if (std::filesystem::is_directory(path, ec)) {
    for (const auto& entry : std::filesystem::directory_iterator(path, ec)) {
      const std::string extension = entry.path().extension().string();
      if (entry.is_regular_file() && (extension == ".jsonl" || extension == ".json"))
        files.push_back(entry.path().string());
    }
    Require(!ec, path + ": cannot list the directory (" + ec.message() + ")");
    Require(!files.empty(), path + ": has no .jsonl or .json file of detections");
    std::sort(files.begin(), files.end());
  } else {
    Require(std::filesystem::exists(path, ec), path + ": no such detections file or directory");
    files.push_back(path);
  }
  ExternalDetections read;
  ContentHasher hash;
  for (const std::string& file : files) ReadFile(file, &read, &hash);
  read.content_hash = hash.HexDigest();
  return read;
}

std::string ExternalDetectionsLine(int64_t frame_id,
                                   const std::vector<ScoredDetection>& detections,
                                   const std::string& detector,
                                   std::optional<double> time_ms) {
  Json list = Json::array();
  for (const ScoredDetection& d : detections) {
    const OrientedBox& box = d.box3d;
    list.push_back(
        {{"class", ClassName(d.furniture_class)},
         {"score", d.score},
         {"centre", {box.centre.x(), box.centre.y(), box.centre.z()}},
         {"size", {box.size.x(), box.size.y(), box.size.z()}},
         {"yaw", box.yaw},
         {"floor_point", {d.x, d.y}},
         {"symmetry", d.symmetry},
         {"model", d.model_id.empty() ? Json(nullptr) : Json(d.model_id)},
         {"size_source", d.width > 0 ? "network" : (d.model_id.empty() ? "class" : "model")}});
  }
  Json line{{"format", kExternalDetectionsFormat},
            {"version", kExternalDetectionsVersion},
            {"frame", frame_id},
            {"detector", detector}};
  if (time_ms && std::isfinite(*time_ms)) line["time_ms"] = *time_ms;
  line["detections"] = list;
  return line.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace furn
