#include "workbench/pipelines/evaluated_frame.h"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "workbench/formats/json_text.h"

namespace furn {

ScoredDetection ScoredDetectionOf(const Detection& d, int symmetry) {
  return {d.box(), d.furniture_class, d.model_name, d.score, symmetry};
}
namespace {

using Json = nlohmann::json;

constexpr const char* kFormat = "furn-evaluate-shard";
constexpr int kVersion = 2;  // 2: each detection with its 3-D box

// JSON has no NaN or infinity: they travel as null (read back as NaN).
Json Number(double value) { return std::isfinite(value) ? Json(value) : Json(nullptr); }
double NumberOf(const Json& value) {
  return value.is_null() ? std::numeric_limits<double>::quiet_NaN() : value.get<double>();
}

// One detection: the evaluation's view and the run's record share every field.
Json DetectionJson(const ScoredDetection& d, const RunDetectionRecord& r) {
  return Json::array({EnumName(d.furniture_class),
                      d.model_id,
                      Number(d.x),
                      Number(d.y),
                      Number(d.yaw),
                      Number(d.score),
                      d.symmetry,
                      Number(d.width),
                      Number(d.depth),
                      Number(r.z),
                      Number(r.vote_weight),
                      Number(r.verification),
                      Number(r.covered_fraction),
                      Number(d.box3d.centre.x()),
                      Number(d.box3d.centre.y()),
                      Number(d.box3d.centre.z()),
                      Number(d.box3d.size.x()),
                      Number(d.box3d.size.y()),
                      Number(d.box3d.size.z()),
                      Number(d.box3d.yaw)});
}

Json FrameJson(const EvaluatedFrame& frame) {
  Json detections = Json::array();
  for (size_t k = 0; k < frame.outcome.detections.size(); ++k)
    detections.push_back(DetectionJson(frame.outcome.detections[k], frame.detections[k]));
  Json maxima = Json::array();
  for (const HoughMaximum& m : frame.outcome.maxima) {
    maxima.push_back(Json::array({EnumName(m.furniture_class),
                                  Number(m.x),
                                  Number(m.y),
                                  Number(m.relative),
                                  EnumName(m.outcome)}));
  }
  Json stage_ms = Json::object();
  for (const auto& [stage, ms] : frame.outcome.stage_ms) stage_ms[EnumName(stage)] = Number(ms);
  return {{"position", frame.position},
          {"frame", frame.outcome.frame_id},
          {"status", EnumName(frame.status)},
          {"total_ms", Number(frame.outcome.total_ms)},
          {"stage_ms", stage_ms},
          {"timings", frame.record.timings_json},
          {"detections", detections},
          {"maxima", maxima}};
}

// Typed, range-checked fields of a shard file (data another machine
// wrote): a wrong type, a fraction where an integer belongs or a value out of
// range is an InputError naming the field and the rule.
int64_t IntegerOf(const Json& value, const char* field, int64_t low, int64_t high) {
  Require(value.is_number_integer(), std::string("'") + field + "' must be an integer");
  const int64_t n = value.is_number_unsigned() && value.get<uint64_t>() > INT64_MAX
                        ? high + 1
                        : value.get<int64_t>();
  Require(n >= low && n <= high,
          std::string("'") + field + "' must be in " + std::to_string(low) + ".." +
              std::to_string(high));
  return n;
}

std::string StringOf(const Json& value, const char* field) {
  Require(value.is_string(), std::string("'") + field + "' must be a string");
  return value.get<std::string>();
}

// A number that may be absent (null: NaN).
double NumberOrNan(const Json& value, const char* field) {
  Require(value.is_null() || value.is_number(),
          std::string("'") + field + "' must be a number or null");
  return NumberOf(value);
}

// A number the run stores (a NOT NULL column): finite.
double FiniteOf(const Json& value, const char* field) {
  Require(value.is_number(), std::string("'") + field + "' must be a finite number");
  return value.get<double>();
}

const Json& Item(const Json& array, size_t index, const char* what) {
  Require(array.is_array() && index < array.size(),
          std::string("a ") + what + " entry must be an array of at least " +
              std::to_string(index + 1) + " values");
  return array[index];
}

constexpr int64_t kMaxPositions = 1000000000;

EvaluatedFrame FrameOf(const Json& json) {
  Require(json.is_object(), "a frame must be an object");
  EvaluatedFrame frame;
  frame.position = static_cast<int>(IntegerOf(json.at("position"), "position", 0, kMaxPositions));
  frame.status = ParseEnum<DetectionStatus>(StringOf(json.at("status"), "status"));
  frame.outcome.frame_id = IntegerOf(json.at("frame"), "frame", 0, INT64_MAX);
  frame.outcome.total_ms = FiniteOf(json.at("total_ms"), "total_ms");
  Require(json.at("stage_ms").is_object(), "'stage_ms' must be an object");
  for (const auto& [stage, ms] : json.at("stage_ms").items())
    frame.outcome.stage_ms[ParseEnum<DetectionStage>(stage)] = NumberOrNan(ms, "stage_ms");
  frame.record = {
      frame.outcome.frame_id, frame.outcome.total_ms, StringOf(json.at("timings"), "timings")};
  Require(json.at("detections").is_array(), "'detections' must be an array");
  for (const Json& d : json.at("detections")) {
    const char* what = "detection";
    const FurnitureClass c = ParseEnum<FurnitureClass>(StringOf(Item(d, 0, what), "class"));
    const std::string model = StringOf(Item(d, 1, what), "model");
    ScoredDetection& s = frame.outcome.detections.emplace_back();
    s.furniture_class = c;
    s.model_id = model;
    s.x = FiniteOf(Item(d, 2, what), "x");
    s.y = FiniteOf(Item(d, 3, what), "y");
    s.yaw = FiniteOf(Item(d, 4, what), "yaw");
    s.score = FiniteOf(Item(d, 5, what), "score");
    s.symmetry = static_cast<int>(IntegerOf(Item(d, 6, what), "symmetry", 1, 4));
    s.width = NumberOrNan(Item(d, 7, what), "width");
    s.depth = NumberOrNan(Item(d, 8, what), "depth");
    frame.detections.push_back({frame.outcome.frame_id,
                                c,
                                model,
                                s.x,
                                s.y,
                                FiniteOf(Item(d, 9, what), "z"),
                                s.yaw,
                                s.score,
                                FiniteOf(Item(d, 10, what), "vote_weight"),
                                FiniteOf(Item(d, 11, what), "verification"),
                                FiniteOf(Item(d, 12, what), "covered_fraction")});
    s.box3d.centre = Eigen::Vector3d(FiniteOf(Item(d, 13, what), "box centre x"),
                                     FiniteOf(Item(d, 14, what), "box centre y"),
                                     FiniteOf(Item(d, 15, what), "box centre z"));
    s.box3d.size = Eigen::Vector3d(FiniteOf(Item(d, 16, what), "box size x"),
                                   FiniteOf(Item(d, 17, what), "box size y"),
                                   FiniteOf(Item(d, 18, what), "box size z"));
    s.box3d.yaw = FiniteOf(Item(d, 19, what), "box yaw");
  }
  Require(json.at("maxima").is_array(), "'maxima' must be an array");
  for (const Json& m : json.at("maxima")) {
    const char* what = "maximum";
    frame.outcome.maxima.push_back(
        {ParseEnum<FurnitureClass>(StringOf(Item(m, 0, what), "class")),
         FiniteOf(Item(m, 1, what), "x"),
         FiniteOf(Item(m, 2, what), "y"),
         NumberOrNan(Item(m, 3, what), "relative"),
         ParseEnum<HypothesisOutcome>(StringOf(Item(m, 4, what), "outcome"))});
  }
  return frame;
}

// The first header field in which `file` differs from `expected`, as the
// end of a one-line error; "" when they agree.
std::string Mismatch(const ShardHeader& file, const ShardHeader& expected) {
  const std::string n = std::to_string(expected.shards);
  if (file.shards != expected.shards || file.shard != expected.shard) {
    return "is shard " + std::to_string(file.shard) + "/" + std::to_string(file.shards) +
           ", expected " + std::to_string(expected.shard) + "/" + n;
  }
  if (file.dataset_hash != expected.dataset_hash)
    return "was evaluated on other frames (another dataset, split, fold or --max-frames)";
  if (file.model_hash != expected.model_hash) return "was evaluated with another model";
  if (file.options_json != expected.options_json)
    return "was evaluated with other options (detector, evaluation or tune trial)";
  return "";
}

}  // namespace

void WriteShardFile(const std::string& path,
                    const ShardHeader& header,
                    const std::vector<EvaluatedFrame>& frames) {
  Json json{{"format", kFormat},
            {"version", kVersion},
            {"shard", header.shard},
            {"shards", header.shards},
            {"dataset_hash", header.dataset_hash},
            {"model_hash", header.model_hash},
            {"options", header.options_json},
            {"frames", Json::array()}};
  for (const EvaluatedFrame& frame : frames) json["frames"].push_back(FrameJson(frame));
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  WriteFileAtomically(path,
                      json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

ShardFile ParseShardFile(const std::string& path) {
  RequireRegularFile(path);
  const Json json = ParseUserJson<Json>(ReadFileBytes(path), path);
  Require(json.is_object() && json.contains("format") && json["format"] == kFormat,
          path + ": not a shard file of 'evaluate --shard' (no \"format\": \"" + kFormat + "\")");
  Require(json.contains("version") && json["version"].is_number_integer() &&
              json["version"] == kVersion,
          path + ": shard file version is not " + std::to_string(kVersion) +
              " (this build reads version " + std::to_string(kVersion) + ")");
  ShardFile file;
  try {
    file.header = {static_cast<int>(IntegerOf(json.at("shard"), "shard", 0, 100000)),
                   static_cast<int>(IntegerOf(json.at("shards"), "shards", 1, 100000)),
                   StringOf(json.at("dataset_hash"), "dataset_hash"),
                   StringOf(json.at("model_hash"), "model_hash"),
                   StringOf(json.at("options"), "options")};
    Require(json.at("frames").is_array(), "'frames' must be an array");
    for (const Json& frame : json.at("frames")) file.frames.push_back(FrameOf(frame));
  } catch (const Json::exception& e) {
    throw InputError(path + ": a broken shard file (" + e.what() + ")");
  } catch (const InputError& e) {
    throw InputError(path + ": a broken shard file (" + e.what() + ")");
  }
  return file;
}

std::vector<EvaluatedFrame> ReadShardFile(const std::string& path, const ShardHeader& expected) {
  Require(std::filesystem::is_regular_file(path),
          path + ": missing: shard " + std::to_string(expected.shard) + " of " +
              std::to_string(expected.shards) + " was not evaluated (rerun its task)");
  ShardFile file = ParseShardFile(path);
  if (const std::string why = Mismatch(file.header, expected); !why.empty())
    throw InputError(path + ": " + why + "; not a shard of this evaluation");
  return std::move(file.frames);
}

}  // namespace furn
