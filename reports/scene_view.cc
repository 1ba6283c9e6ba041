#include "reports/scene_view.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/detector/detection_box.h"
#include "core/geometry/conventions.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/class_colours.h"
#include "reports/evaluation.h"
#include "reports/run_report.h"
#include "reports/scene_assets.h"

namespace furn {
namespace {

using Json = nlohmann::ordered_json;

constexpr double kMatchM = 0.10;  // a detection this near a true object of its class found it
constexpr double kFunnelWindowM = 0.15;  // a maximum this near an object is about it (evaluation)
constexpr double kTargetVisibility = 0.25;

std::string Base64(const std::string& bytes) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t group = static_cast<uint8_t>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) group |= static_cast<uint8_t>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) group |= static_cast<uint8_t>(bytes[i + 2]);
    out += kAlphabet[(group >> 18) & 63];
    out += kAlphabet[(group >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(group >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[group & 63] : '=';
  }
  return out;
}

// Little-endian int16 values as bytes.
void AppendInt16(int value, std::string* bytes) {
  const auto v = static_cast<uint16_t>(static_cast<int16_t>(std::clamp(value, -32767, 32767)));
  bytes->push_back(static_cast<char>(v & 0xff));
  bytes->push_back(static_cast<char>(v >> 8));
}

std::string HexColour(std::optional<FurnitureClass> furniture_class) {
  const std::array<uint8_t, 3> rgb = ClassColourRgb(furniture_class);
  char text[8];
  std::snprintf(text, sizeof(text), "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
  return text;
}

Json BoxJson(const OrientedBox& box) {
  return {{"centre", {box.centre.x(), box.centre.y(), box.centre.z()}},
          {"size", {box.size.x(), box.size.y(), box.size.z()}},
          {"yaw", box.yaw}};
}

// Points as int16 millimetres from `origin` (every k-th beyond the cap; a
// point farther than 32 m from it is left out), with their segments.
Json PointsJson(const DetectionDebug& debug, const Eigen::Vector3f& origin) {
  const size_t n = debug.points.size();
  const size_t stride = std::max<size_t>(1, (n + kSceneMaxPoints - 1) / kSceneMaxPoints);
  std::string xyz, segments;
  size_t kept = 0;
  bool any_segment = false;
  for (size_t i = 0; i < n; i += stride) {
    const Eigen::Vector3f mm = (debug.points[i] - origin) * 1000.0f;
    if (!mm.allFinite() || mm.cwiseAbs().maxCoeff() > 32000.0f) continue;
    for (int k = 0; k < 3; ++k) AppendInt16(static_cast<int>(std::lround(mm[k])), &xyz);
    const int segment = i < debug.segment_of_point.size() ? debug.segment_of_point[i] : -1;
    any_segment |= segment >= 0;
    AppendInt16(segment, &segments);
    ++kept;
  }
  return {{"count", kept},
          {"stride", stride},
          {"xyz_mm", Base64(xyz)},
          {"segment", any_segment ? Json(Base64(segments)) : Json(nullptr)}};
}

// The fitted models' points, each with the index of its detection.
Json FittedJson(const DetectionDebug& debug, const Eigen::Vector3f& origin) {
  std::string xyz, owner;
  size_t kept = 0;
  for (size_t d = 0; d < debug.fitted_points.size(); ++d) {
    for (const Eigen::Vector3f& p : debug.fitted_points[d]) {
      const Eigen::Vector3f mm = (p - origin) * 1000.0f;
      if (!mm.allFinite() || mm.cwiseAbs().maxCoeff() > 32000.0f) continue;
      for (int k = 0; k < 3; ++k) AppendInt16(static_cast<int>(std::lround(mm[k])), &xyz);
      AppendInt16(static_cast<int>(d), &owner);
      ++kept;
    }
  }
  return {{"count", kept}, {"xyz_mm", Base64(xyz)}, {"detection", Base64(owner)}};
}

// The learned heat of every class as one RGBA image, row 0 at the smallest
// y (a texture's first row is its bottom): the hottest class's colour, alpha
// the square root of its heat (none below 0.05). Null on the codebook path.
Json HeatJson(const DetectionDebug& debug) {
  const DetectionDebug::VoteGrid* first = nullptr;
  for (const DetectionDebug::VoteGrid& g : debug.grids)
    if (g.learned && !g.values.empty() && first == nullptr) first = &g;
  if (first == nullptr) return nullptr;
  const size_t cells = static_cast<size_t>(first->rows) * first->cols;
  std::string rgba(4 * cells, '\0');
  for (const DetectionDebug::VoteGrid& g : debug.grids) {
    if (!g.learned || g.rows != first->rows || g.cols != first->cols) continue;
    const std::array<uint8_t, 3> rgb = ClassColourRgb(g.furniture_class);
    for (size_t cell = 0; cell < cells; ++cell) {
      // Alpha the square root of the heat (a weak peak is still seen), below
      // 0.05 none (the network's faint floor everywhere hides nothing).
      const float heat = std::clamp(g.values[cell], 0.0f, 1.0f);
      if (heat < 0.05f) continue;
      const auto alpha = static_cast<char>(std::lround(255 * std::sqrt(heat)));
      if (static_cast<uint8_t>(alpha) <= static_cast<uint8_t>(rgba[4 * cell + 3])) continue;
      rgba.replace(
          4 * cell,
          4,
          {static_cast<char>(rgb[0]), static_cast<char>(rgb[1]), static_cast<char>(rgb[2]), alpha});
    }
  }
  return {{"rgba", Base64(rgba)},
          {"origin", {first->origin.x(), first->origin.y()}},
          {"cell_m", first->cell_m},
          {"cols", first->cols},
          {"rows", first->rows}};
}

Json CameraJson(const DetectionResult& result, const CameraIntrinsics& camera) {
  Json rows = Json::array();
  for (const auto& row : PoseRows(result.world_from_camera)) rows.push_back(row);
  return {{"world_from_camera", rows},
          {"width", camera.width},
          {"height", camera.height},
          {"fx", camera.fx},
          {"fy", camera.fy},
          {"cx", camera.cx},
          {"cy", camera.cy}};
}

// What became of each true object and what each detection is, by the
// evaluation's protocol B on this one frame (evaluation.h MatchFrame, 10 cm)
// and its funnel. The page does not know the run's range: no object is
// ignored for its distance. A visibility not known counts as fully seen.
struct Fates {
  std::vector<std::string> truth, detections;
  std::vector<bool> missed, target;
};
Fates FatesOf(const DetectionResult& result, const std::vector<GroundTruthFootprint>& truth) {
  const EvaluationOptions rules;
  FrameOutcome frame;
  for (const GroundTruthFootprint& g : truth) {
    TruthObject object;
    object.furniture_class = g.furniture_class;
    object.model_id = g.model_id;
    object.box() = g.box();
    object.visibility = g.visibility < 0 ? 1.0 : g.visibility;
    frame.truth.push_back(object);
  }
  for (const Detection& d : result.detections) {
    frame.detections.push_back({d.box(), d.furniture_class, d.model_name, d.score, 1});
  }
  for (const DetectionDebug::Hypothesis& h : result.debug.hypotheses)
    frame.maxima.push_back({h.furniture_class, h.x, h.y, h.relative_weight, h.outcome});
  const FrameMatch match = MatchFrame(frame, rules, kMatchM);
  Fates fates{std::vector<std::string>(truth.size()),
              std::vector<std::string>(result.detections.size(), "no ground truth here"),
              std::vector<bool>(truth.size(), false),
              match.target};
  std::vector<bool> found(truth.size(), false);
  char text[160];
  for (size_t k = 0; k < result.detections.size() && !truth.empty(); ++k) {
    const int t = match.truth_of_detection[k];
    if (t < 0) {
      fates.detections[k] = t == FrameMatch::kFalseDetection
                                ? "false detection (no free true object within 10 cm)"
                                : "on an object too little seen to count (neither true nor false)";
      continue;
    }
    const double off =
        std::hypot(truth[t].x - result.detections[k].x, truth[t].y - result.detections[k].y);
    std::snprintf(text, sizeof(text), "true detection, %.0f cm off", 100 * off);
    fates.detections[k] = text;
    std::snprintf(text,
                  sizeof(text),
                  "found (score %.2f, %.0f cm off)",
                  result.detections[k].score,
                  100 * off);
    fates.truth[t] = text;
    found[t] = true;
  }
  for (size_t t = 0; t < truth.size(); ++t) {
    if (found[t] || !truth[t].furniture_class) continue;
    if (!fates.target[t]) {
      fates.truth[t] = "barely visible or out of view: not a target";
      continue;
    }
    fates.truth[t] = "missed: lost at " +
                     FunnelStageWords(LostAt(frame.truth[t], frame.maxima, rules.funnel_window_m));
    fates.missed[t] = true;
  }
  return fates;
}

Json TruthJson(const std::vector<GroundTruthFootprint>& truth, const Fates& fates) {
  Json objects = Json::array();
  for (size_t t = 0; t < truth.size(); ++t) {
    const GroundTruthFootprint& g = truth[t];
    const double height = g.height > 0 ? g.height : 0.8;
    Json object = BoxJson(WorldBoxOf(g, 0, height));
    object["class"] = g.furniture_class ? Json(ClassName(*g.furniture_class)) : Json(nullptr);
    object["model"] = g.model_id.empty() ? Json(nullptr) : Json(g.model_id);
    object["visibility"] = g.visibility >= 0 ? Json(g.visibility) : Json(nullptr);
    object["fate"] = g.furniture_class ? fates.truth[t] : "clutter";
    object["missed"] = static_cast<bool>(fates.missed[t]);
    object["target"] = static_cast<bool>(fates.target[t]);
    objects.push_back(object);
  }
  return objects;
}

Json DetectionsJson(const DetectionResult& result, const TrainedModel& model, const Fates& fates) {
  Json detections = Json::array();
  for (size_t k = 0; k < result.detections.size(); ++k) {
    const Detection& d = result.detections[k];
    Json detection = BoxJson(DetectionBoxInWorld(d, model));
    detection["class"] = ClassName(d.furniture_class);
    detection["score"] = d.score;
    detection["model"] = d.model_name.empty() ? Json(nullptr) : Json(d.model_name);
    detection["fate"] = fates.detections[k];
    detections.push_back(detection);
  }
  return detections;
}

Json MaximaJson(const DetectionDebug& debug) {
  Json maxima = Json::array();
  for (const DetectionDebug::Hypothesis& h : debug.hypotheses) {
    maxima.push_back({{"class", ClassName(h.furniture_class)},
                      {"x", h.x},
                      {"y", h.y},
                      {"value", h.vote_weight},
                      {"detected", h.outcome == HypothesisOutcome::kDetected},
                      {"outcome", DetectionDebug::Describe(h)}});
  }
  return maxima;
}

Json SceneJson(const DetectionResult& result,
               const TrainedModel& model,
               const CameraIntrinsics& camera,
               const std::vector<GroundTruthFootprint>& truth,
               const SceneViewLinks& links) {
  const Eigen::Vector3f sensor = result.world_from_camera.translation().cast<float>();
  const Eigen::Vector3f origin(std::round(sensor.x()), std::round(sensor.y()), 0.0f);
  const Fates fates = FatesOf(result, truth);
  Json colours = Json::object();
  for (FurnitureClass c : kAllClasses) colours[ClassName(c)] = HexColour(c);
  return {
      {"format", 1},
      {"conventions", "REP 103 world frame: metres, z up, box x along the object's front"},
      {"title", links.title},
      {"origin", {origin.x(), origin.y(), origin.z()}},
      {"colours", colours},
      {"points", PointsJson(result.debug, origin)},
      {"fitted", FittedJson(result.debug, origin)},
      {"camera", CameraJson(result, camera)},
      {"truth", TruthJson(truth, fates)},
      {"detections", DetectionsJson(result, model, fates)},
      {"maxima", MaximaJson(result.debug)},
      {"heat", HeatJson(result.debug)},
      {"navigation", {{"previous", links.previous}, {"next", links.next}, {"index", links.index}}}};
}

std::string Replaced(std::string text, const std::string& key, const std::string& value) {
  for (size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + value.size()))
    text.replace(at, key.size(), value);
  return text;
}

}  // namespace

void WriteSceneLibrary(const std::string& dir) {
  const std::filesystem::path three(FURN_THREE_JS_DIR);
  const std::filesystem::path controls = three / "examples/js/controls/OrbitControls.js";
  Require(std::filesystem::is_regular_file(three / "three.min.js") &&
              std::filesystem::is_regular_file(controls),
          std::string(FURN_THREE_JS_DIR) +
              ": three.js is missing (apt-get install libjs-three, or tools/install_deps.sh)");
  MakeDirectories(dir, "viewer's library folder");
  const std::filesystem::path out(dir);
  WriteFileAtomically((out / "three.min.js").string(),
                      ReadFileBytes((three / "three.min.js").string()));
  WriteFileAtomically((out / "OrbitControls.js").string(), ReadFileBytes(controls.string()));
  WriteFileAtomically((out / "scene_viewer.js").string(), kSceneViewerJs);
  WriteFileAtomically((out / "VERSION").string(),
                      "three.js r" FURN_THREE_JS_REVISION
                      " (Debian package libjs-three), MIT licence: "
                      "/usr/share/doc/libjs-three/copyright\n"
                      "scene_viewer.js: furnidet, BSD-3-Clause\n");
}

void WriteSceneView(const DetectionResult& result,
                    const TrainedModel& model,
                    const CameraIntrinsics& camera,
                    const std::vector<GroundTruthFootprint>& ground_truth,
                    const std::string& dir,
                    const SceneViewLinks& links) {
  MakeDirectories(dir, "scene folder");
  const std::filesystem::path out(dir);
  const std::string library = links.library.empty() ? "three" : links.library;
  if (links.library.empty()) WriteSceneLibrary((out / "three").string());
  // "</" or "<!--" inside a string would end the script early: each "<" as \u003c.
  const std::string data =
      Replaced(SceneJson(result, model, camera, ground_truth, links)
                   .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
               "<",
               "\\u003c");
  WriteFileAtomically((out / "scene_data.js").string(), "window.FURN_SCENE = " + data + ";\n");
  std::string page = Replaced(kSceneHtml, "@TITLE@", HtmlEscape(links.title));
  page = Replaced(page, "@LIBRARY@", HtmlEscape(library));
  WriteFileAtomically((out / "scene.html").string(), page);
}

}  // namespace furn
