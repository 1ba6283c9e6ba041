#include "workbench/formats/detection_output.h"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/detector/detection_box.h"

namespace furn {

std::string DetectionLine(const Detection& d) {
  char line[256];
  std::snprintf(line,
                sizeof(line),
                "%-9s x %6.2f  y %6.2f  yaw %6.1f deg  score %.2f",
                ClassName(d.furniture_class),
                d.x,
                d.y,
                Rep103YawFromModelYaw(d.yaw) * 180 / M_PI,
                d.score);
  std::string text = line;
  if (d.model_index >= 0) text += "  " + d.model_name;
  if (d.width > 0) {
    // REP 103: along the front, then across.
    std::snprintf(line, sizeof(line), "  footprint %.2f x %.2f m", d.depth, d.width);
    text += line;
  }
  if (d.in_view < 1) {  // cut by the frame: the centre is a guess from the part in view
    std::snprintf(line, sizeof(line), "  %.0f %% in view", 100 * d.in_view);
    text += line;
  }
  return text;
}

namespace {

// A number, or null where the value does not exist (an unfitted detection
// has no verification).
nlohmann::ordered_json NumberOrNull(bool exists, double value) {
  return exists ? nlohmann::ordered_json(value) : nlohmann::ordered_json(nullptr);
}

nlohmann::ordered_json Vector3Json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

nlohmann::ordered_json DetectionBoxJson(const Detection& d, const TrainedModel& model) {
  const OrientedBox box = DetectionBoxInWorld(d, model);
  const bool fitted = d.model_index >= 0;
  return {
      {"class", ClassName(d.furniture_class)},
      {"score", d.score},
      {"centre", Vector3Json(box.centre)},
      {"size", Vector3Json(box.size)},
      {"yaw", box.yaw},
      {"quaternion", QuaternionXyzw(box.yaw)},
      {"floor_point", {d.x, d.y}},
      {"model", fitted ? nlohmann::ordered_json(d.model_name) : nlohmann::ordered_json(nullptr)},
      {"size_source", d.width > 0 ? "network" : (fitted ? "model" : "class")},
      {"in_view", d.in_view},
      {"vote_weight", d.vote_weight},
      {"verification", NumberOrNull(fitted, d.verification)},
      {"covered_fraction", NumberOrNull(fitted, d.covered_fraction)}};
}

namespace {

nlohmann::ordered_json CameraJson(const LoadedScan& scan) {
  if (scan.camera_source.empty()) return nullptr;
  const CameraIntrinsics& c = scan.camera;
  return {{"source", scan.camera_source},
          {"width", c.width},
          {"height", c.height},
          {"fx", c.fx},
          {"fy", c.fy},
          {"cx", c.cx},
          {"cy", c.cy}};
}

}  // namespace

std::string DetectionJson(const DetectionResult& result,
                          const LoadedScan& scan,
                          const TrainedModel& model,
                          const DetectionProvenance& provenance,
                          bool one_line) {
  nlohmann::ordered_json detections = nlohmann::ordered_json::array();
  for (const Detection& d : result.detections) detections.push_back(DetectionBoxJson(d, model));
  nlohmann::ordered_json timings = nlohmann::ordered_json::object();
  for (const StageTime& t : result.timings_ms.stages) timings[EnumName(t.stage)] = t.ms;
  nlohmann::ordered_json json{
      {"format", kDetectionJsonFormat},
      {"conventions", kConventionsText},
      {"input", scan.description},
      {"dataset_frame",
       scan.dataset_frame >= 0 ? nlohmann::ordered_json(scan.dataset_frame) : nullptr},
      {"world_from_camera", PoseRows(result.world_from_camera)},
      {"floor_estimated", result.floor_estimated},
      {"pose_source",
       scan.pose_source.empty() ? std::string(result.floor_estimated ? "floor estimated" : "given")
                                : scan.pose_source},
      {"camera", CameraJson(scan)},
      {"program", std::string("furnidet ") + FURN_VERSION},
      {"model_file", {{"path", provenance.model_path}, {"hash", provenance.model_hash}}},
      {"points_in_range", result.input_points},
      {"points", result.scene_points},
      {"segments", result.segments},
      {"detections", detections},
      {"timings_ms", timings}};
  return (one_line ? json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)
                   : json.dump(2, ' ', false, nlohmann::json::error_handler_t::replace)) +
         "\n";
}

std::string ScanErrorJson(const std::string& input, const std::string& error) {
  return nlohmann::ordered_json{{"input", input}, {"error", error}}.dump(
             -1, ' ', false, nlohmann::json::error_handler_t::replace) +
         "\n";
}

namespace {

// The highest-scoring fit of a hypothesis (the first of equals), or null.
const DetectionDebug::Hypothesis::Fit* BestFit(const DetectionDebug::Hypothesis& h) {
  const DetectionDebug::Hypothesis::Fit* best = nullptr;
  for (const DetectionDebug::Hypothesis::Fit& f : h.fits) {
    if (best == nullptr || f.score > best->score) best = &f;
  }
  return best;
}

const char* ModelNameOf(const TrainedModel& model, int index) {
  return index >= 0 && index < static_cast<int>(model.model_names.size())
             ? model.model_names[index].c_str()
             : "?";
}

// What moved a learned maximum's centre from its peak cell's own vote: the
// dense votes' mean shift and/or the sides its cells' edge votes placed.
std::string LearnedPlacement(const DetectionDebug::Hypothesis& h) {
  const DetectionDebug::LearnedPeak& peak = *h.learned;
  const double moved = std::hypot(peak.peak_x - h.x, peak.peak_y - h.y);
  char text[128];
  std::string out;
  if (peak.votes > 0) {
    std::snprintf(
        text, sizeof(text), "votes %.0f (%.2f m from the peak cell's)  ", peak.votes, moved);
    out += text;
  }
  if (peak.edge_cells > 0) {
    std::snprintf(text,
                  sizeof(text),
                  "sides placed by %d cells (%.2f m from the peak cell's)  ",
                  peak.edge_cells,
                  moved);
    out += text;
  }
  return out;
}

}  // namespace

std::string ExplainDetection(const DetectionResult& result, const TrainedModel& model) {
  std::ostringstream out;
  const bool learned =
      !result.debug.hypotheses.empty() && result.debug.hypotheses.front().learned.has_value();
  out << result.debug.hypotheses.size()
      << (learned ? " hypotheses (learned heat maxima):\n" : " hypotheses (Hough maxima):\n");
  char line[256];
  for (const DetectionDebug::Hypothesis& h : result.debug.hypotheses) {
    if (h.learned) {
      const DetectionDebug::LearnedPeak& peak = *h.learned;
      std::snprintf(line,
                    sizeof(line),
                    "  %-9s x %6.2f  y %6.2f  yaw %6.1f deg  footprint %.2f x %.2f m  heat %.3f  ",
                    ClassName(h.furniture_class),
                    h.x,
                    h.y,
                    Rep103YawFromModelYaw(h.yaw) * 180 / M_PI,
                    h.depth,
                    h.width,
                    h.vote_weight);
      out << line;
      out << LearnedPlacement(h);
      if (const DetectionDebug::Hypothesis::Fit* best = BestFit(h)) {  // learned_fit
        std::snprintf(line,
                      sizeof(line),
                      "fit %s %.2f m away (%s)  ",
                      ModelNameOf(model, best->model_index),
                      std::hypot(h.fit_x - h.x, h.fit_y - h.y),
                      peak.refined ? "agrees: its yaw and model" : "disagrees: the network's yaw");
        out << line;
      }
      if (peak.extent_edges >= 0) {
        std::snprintf(line,
                      sizeof(line),
                      "extent: %d of 4 edges seen, moved %.2f m  ",
                      peak.extent_edges,
                      peak.extent_moved_m);
        out << line;
      }
      out << "-> " << DetectionDebug::Describe(h) << "\n";
      continue;
    }
    std::snprintf(line,
                  sizeof(line),
                  "  %-9s x %6.2f  y %6.2f  votes %6.2f (rel %.2f)  %zu segments  ",
                  ClassName(h.furniture_class),
                  h.x,
                  h.y,
                  h.vote_weight,
                  h.relative_weight,
                  h.segments.size());
    out << line;
    // The best fit, if any: the one the outcome is about.
    if (const DetectionDebug::Hypothesis::Fit* best = BestFit(h)) {
      std::snprintf(line,
                    sizeof(line),
                    "fit %s covered %.2f verification %.2f",
                    ModelNameOf(model, best->model_index),
                    best->covered_fraction,
                    best->verification);
      out << line;
      if (h.probability >= 0) {
        std::snprintf(line, sizeof(line), " p %.2f", h.probability);
        out << line;
      }
      out << "  ";
    }
    out << "-> " << DetectionDebug::Describe(h) << "\n";
  }
  return out.str();
}

}  // namespace furn
