#include "workbench/pipelines/evaluated_frame.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/file_util.h"

namespace furn {
namespace {

using Json = nlohmann::json;

constexpr const char* kFormat = "furn-evaluate-shard";
constexpr int kVersion = 1;

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
                      Number(r.covered_fraction)});
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

EvaluatedFrame FrameOf(const Json& json) {
  EvaluatedFrame frame;
  frame.position = json.at("position").get<int>();
  frame.status = ParseEnum<DetectionStatus>(json.at("status").get<std::string>());
  frame.outcome.frame_id = json.at("frame").get<int64_t>();
  frame.outcome.total_ms = NumberOf(json.at("total_ms"));
  for (const auto& [stage, ms] : json.at("stage_ms").items())
    frame.outcome.stage_ms[ParseEnum<DetectionStage>(stage)] = NumberOf(ms);
  frame.record = {frame.outcome.frame_id, frame.outcome.total_ms, json.at("timings")};
  for (const Json& d : json.at("detections")) {
    const FurnitureClass c = ParseEnum<FurnitureClass>(d.at(0).get<std::string>());
    const std::string model = d.at(1).get<std::string>();
    frame.outcome.detections.push_back({c,
                                        model,
                                        NumberOf(d.at(2)),
                                        NumberOf(d.at(3)),
                                        NumberOf(d.at(4)),
                                        NumberOf(d.at(5)),
                                        d.at(6).get<int>(),
                                        NumberOf(d.at(7)),
                                        NumberOf(d.at(8))});
    const ScoredDetection& s = frame.outcome.detections.back();
    frame.detections.push_back({frame.outcome.frame_id,
                                c,
                                model,
                                s.x,
                                s.y,
                                NumberOf(d.at(9)),
                                s.yaw,
                                s.score,
                                NumberOf(d.at(10)),
                                NumberOf(d.at(11)),
                                NumberOf(d.at(12))});
  }
  for (const Json& m : json.at("maxima")) {
    frame.outcome.maxima.push_back({ParseEnum<FurnitureClass>(m.at(0).get<std::string>()),
                                    NumberOf(m.at(1)),
                                    NumberOf(m.at(2)),
                                    NumberOf(m.at(3)),
                                    ParseEnum<HypothesisOutcome>(m.at(4).get<std::string>())});
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
  WriteFileAtomically(path, json.dump() + "\n");
}

std::vector<EvaluatedFrame> ReadShardFile(const std::string& path, const ShardHeader& expected) {
  Require(std::filesystem::is_regular_file(path),
          path + ": missing: shard " + std::to_string(expected.shard) + " of " +
              std::to_string(expected.shards) + " was not evaluated (rerun its task)");
  Json json;
  try {
    json = Json::parse(ReadFileBytes(path));
  } catch (const Json::exception& e) {
    throw InputError(path + ": not a shard file of 'evaluate --shard' (" + e.what() + ")");
  }
  Require(json.is_object() && json.value("format", "") == kFormat,
          path + ": not a shard file of 'evaluate --shard' (no \"format\": \"" + kFormat + "\")");
  Require(json.value("version", 0) == kVersion,
          path + ": shard file version " + json.value("version", Json()).dump() +
              ", this build reads version " + std::to_string(kVersion));
  ShardHeader header;
  try {
    header = {json.at("shard").get<int>(),
              json.at("shards").get<int>(),
              json.at("dataset_hash").get<std::string>(),
              json.at("model_hash").get<std::string>(),
              json.at("options").get<std::string>()};
  } catch (const Json::exception& e) {
    throw InputError(path + ": a broken shard file header (" + e.what() + ")");
  }
  if (const std::string why = Mismatch(header, expected); !why.empty())
    throw InputError(path + ": " + why + "; not a shard of this evaluation");
  std::vector<EvaluatedFrame> frames;
  try {
    for (const Json& frame : json.at("frames")) frames.push_back(FrameOf(frame));
  } catch (const Json::exception& e) {
    throw InputError(path + ": a broken shard file (" + e.what() + ")");
  } catch (const InputError& e) {
    throw InputError(path + ": a broken shard file (" + e.what() + ")");
  }
  return frames;
}

}  // namespace furn
