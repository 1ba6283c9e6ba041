#include "reports/detection_debug.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/png_file.h"
#include "reports/scene_view.h"

namespace furn {
namespace {

// A distinct, stable colour per segment (golden-angle hues).
cv::Scalar SegmentColour(int segment) {
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(static_cast<int>(segment * 137.508) % 180, 200, 255));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return cv::Scalar(c[0], c[1], c[2]);
}

// Camera-view canvas: projects world points through the inverse pose.
class CameraView {
 public:
  CameraView(const CameraIntrinsics& camera, const Eigen::Isometry3d& world_from_camera)
      : camera_(camera),
        camera_from_world_(world_from_camera.inverse().cast<float>()),
        image_(camera.height, camera.width, CV_8UC3, cv::Scalar(0, 0, 0)),
        depth_(camera.height, camera.width, CV_32F, cv::Scalar(1e9f)) {}

  // Draws a 2x2 dot unless something nearer is already there.
  void Dot(const Eigen::Vector3f& world, const cv::Scalar& colour) {
    const Eigen::Vector3f p = camera_from_world_ * world;
    if (p.z() <= 0.05f) return;
    const Eigen::Vector2d pixel = camera_.Project(p.cast<double>());
    const int u = static_cast<int>(pixel.x()), v = static_cast<int>(pixel.y());
    for (int dv = 0; dv < 2; ++dv) {
      for (int du = 0; du < 2; ++du) {
        const int x = u + du, y = v + dv;
        if (x < 0 || y < 0 || x >= image_.cols || y >= image_.rows) continue;
        float& nearest = depth_.at<float>(y, x);
        if (p.z() > nearest) continue;
        nearest = p.z();
        image_.at<cv::Vec3b>(y, x) = cv::Vec3b(colour[0], colour[1], colour[2]);
      }
    }
  }
  std::optional<cv::Point> Pixel(const Eigen::Vector3f& world) const {
    const Eigen::Vector3f p = camera_from_world_ * world;
    if (p.z() <= 0.05f) return std::nullopt;
    const Eigen::Vector2d pixel = camera_.Project(p.cast<double>());
    return cv::Point(static_cast<int>(pixel.x()), static_cast<int>(pixel.y()));
  }
  // The 12 edges of a box posed at `pose` with its base at height z (an edge
  // with an end behind the camera is left out).
  void Box(const PlanarPose& pose,
           float z,
           const Eigen::Vector3f& low,
           const Eigen::Vector3f& high,
           const cv::Scalar& colour,
           int thickness) {
    std::optional<cv::Point> corners[8];
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3f local(
          (k & 1) ? high.x() : low.x(), (k & 2) ? high.y() : low.y(), (k & 4) ? high.z() : low.z());
      corners[k] = Pixel(pose.Apply(local) + Eigen::Vector3f(0, 0, z));
    }
    for (int a = 0; a < 8; ++a) {
      for (int bit : {1, 2, 4}) {
        const int b = a | bit;
        if (b == a || !corners[a] || !corners[b]) continue;
        cv::line(image_, *corners[a], *corners[b], colour, thickness, cv::LINE_AA);
      }
    }
  }
  cv::Mat& image() { return image_; }

 private:
  CameraIntrinsics camera_;
  Eigen::Isometry3f camera_from_world_;
  cv::Mat image_;
  cv::Mat depth_;
};

cv::Scalar GreyForDistance(float distance) {
  const int level = static_cast<int>(std::clamp(230.0f - 45.0f * distance, 60.0f, 230.0f));
  return cv::Scalar(level, level, level);
}

// Top-down canvas over a world xy rectangle, y up, `pixels_per_metre`.
class TopDown {
 public:
  static cv::Scalar GridColour(int metre) {
    return metre == 0 ? cv::Scalar(90, 90, 90) : cv::Scalar(52, 52, 52);
  }
  TopDown(const Eigen::Vector2f& low, const Eigen::Vector2f& high, double pixels_per_metre)
      : low_(low), high_(high), scale_(pixels_per_metre) {
    image_ = cv::Mat(static_cast<int>((high.y() - low.y()) * scale_) + 1,
                     static_cast<int>((high.x() - low.x()) * scale_) + 1,
                     CV_8UC3,
                     cv::Scalar(24, 24, 24));
  }
  cv::Point At(double x, double y) const {
    return cv::Point(static_cast<int>((x - low_.x()) * scale_),
                     static_cast<int>((high_.y() - y) * scale_));
  }
  // The footprint rectangle of a posed box (model-frame corners low/high).
  void Footprint(const PlanarPose& pose,
                 const Eigen::Vector2f& low,
                 const Eigen::Vector2f& high,
                 const cv::Scalar& colour,
                 int thickness) {
    std::vector<cv::Point> corners;
    for (const Eigen::Vector2f& corner :
         {low, Eigen::Vector2f(high.x(), low.y()), high, Eigen::Vector2f(low.x(), high.y())}) {
      const Eigen::Vector3f w = pose.Apply(Eigen::Vector3f(corner.x(), corner.y(), 0));
      corners.push_back(At(w.x(), w.y()));
    }
    cv::polylines(image_, corners, true, colour, thickness, cv::LINE_AA);
    // Front (-y in the model frame) marked by a tick from the centre.
    const Eigen::Vector3f front = pose.Apply(Eigen::Vector3f(0, low.y(), 0));
    cv::line(image_, At(pose.x, pose.y), At(front.x(), front.y()), colour, 1, cv::LINE_AA);
  }
  // Lines every metre (brighter at whole metres of 0) and a 1 m scale bar.
  void Grid() {
    for (int x = static_cast<int>(std::ceil(low_.x())); x <= high_.x(); ++x) {
      cv::line(image_, At(x, low_.y()), At(x, high_.y()), GridColour(x), 1);
      DrawLabel(&image_,
                std::to_string(x) + " m",
                At(x, low_.y()) + cv::Point(3, -4),
                cv::Scalar(140, 140, 140),
                0.35);
    }
    for (int y = static_cast<int>(std::ceil(low_.y())); y <= high_.y(); ++y) {
      cv::line(image_, At(low_.x(), y), At(high_.x(), y), GridColour(y), 1);
      DrawLabel(&image_,
                std::to_string(y) + " m",
                At(low_.x(), y) + cv::Point(3, -4),
                cv::Scalar(140, 140, 140),
                0.35);
    }
    const cv::Point start(image_.cols - static_cast<int>(scale_) - 16, image_.rows - 40);
    cv::line(image_,
             start,
             start + cv::Point(static_cast<int>(scale_), 0),
             cv::Scalar(230, 230, 230),
             2);
    DrawLabel(&image_,
              "1 m",
              start + cv::Point(static_cast<int>(scale_) / 2 - 10, -6),
              cv::Scalar(230, 230, 230),
              0.4);
  }
  cv::Mat& image() { return image_; }

 private:
  Eigen::Vector2f low_, high_;
  double scale_;
  cv::Mat image_;
};

// The figure's caption at its top, wrapped at spaces into as many lines as
// the image's width needs (a narrow top-down view cut it off).
void Caption(cv::Mat* image, const std::string& text) {
  constexpr double kScale = 0.45;
  std::vector<std::string> lines(1);
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find(' ', start);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(start, end - start);
    const std::string longer = lines.back().empty() ? word : lines.back() + " " + word;
    int baseline = 0;
    const int width = cv::getTextSize(longer, cv::FONT_HERSHEY_SIMPLEX, kScale, 3, &baseline).width;
    if (width > image->cols - 12 && !lines.back().empty()) {
      lines.push_back(word);
    } else {
      lines.back() = longer;
    }
    start = end + 1;
  }
  for (size_t k = 0; k < lines.size(); ++k)
    DrawLabel(image,
              lines[k],
              cv::Point(6, 16 + 16 * static_cast<int>(k)),
              cv::Scalar(255, 255, 255),
              kScale);
}

// What every debug figure is drawn from.
struct DebugInput {
  const DetectionResult& result;
  const TrainedModel& model;
  const CameraIntrinsics& camera;
  const std::vector<GroundTruthFootprint>& ground_truth;
  std::string dir;

  const DetectionDebug& debug() const { return result.debug; }
  Eigen::Vector3f sensor() const { return result.world_from_camera.translation().cast<float>(); }
  std::string Path(const std::string& name) const {
    return (std::filesystem::path(dir) / name).string();
  }
};

bool LearnedRun(const DetectionDebug& debug) {
  return std::any_of(
      debug.grids.begin(), debug.grids.end(), [](const auto& g) { return g.learned; });
}

// Segments, from the camera (the codebook path).
void WriteSegmentsPng(const DebugInput& in) {
  CameraView view(in.camera, in.result.world_from_camera);
  for (size_t i = 0; i < in.debug().points.size(); ++i) {
    const int s = in.debug().segment_of_point[i];
    view.Dot(in.debug().points[i], s < 0 ? cv::Scalar(90, 90, 90) : SegmentColour(s));
  }
  Caption(&view.image(),
          std::to_string(in.result.segments) + " segments of " +
              std::to_string(in.result.scene_points) + " points (floor removed)");
  WritePngAtomically(view.image(), in.Path("segments.png"));
}

// The strongest learned heat under a world point and its class (none below 0.02).
std::pair<std::optional<FurnitureClass>, float> HeatAt(const DetectionDebug& debug,
                                                       const Eigen::Vector3f& p) {
  std::pair<std::optional<FurnitureClass>, float> best{std::nullopt, 0.02f};
  for (const DetectionDebug::VoteGrid& g : debug.grids) {
    if (!g.learned || g.cell_m <= 0) continue;
    const int col = static_cast<int>(std::floor((p.x() - g.origin.x()) / g.cell_m));
    const int row = static_cast<int>(std::floor((p.y() - g.origin.y()) / g.cell_m));
    if (col < 0 || row < 0 || col >= g.cols || row >= g.rows) continue;
    const float value = g.values[static_cast<size_t>(row) * g.cols + col];
    if (value > best.second) best = {g.furniture_class, value};
  }
  return best;
}

// The hypotheses, the detected ones first (their labels are placed first).
std::vector<const DetectionDebug::Hypothesis*> DetectedFirst(const DetectionDebug& debug) {
  std::vector<const DetectionDebug::Hypothesis*> ordered;
  for (const DetectionDebug::Hypothesis& h : debug.hypotheses) ordered.push_back(&h);
  std::stable_partition(ordered.begin(), ordered.end(), [](const DetectionDebug::Hypothesis* h) {
    return h->outcome == HypothesisOutcome::kDetected;
  });
  return ordered;
}

// How many labels a figure left out for want of room, for its caption.
std::string LeftOut(const LabelLayout& labels) {
  return labels.left_out() == 0
             ? std::string()
             : ", " + std::to_string(labels.left_out()) + " unlabelled (no room)";
}

// The learned path, from the camera: each point in the colour of the class
// whose heat is strongest under it (brighter: hotter), and every maximum on
// the floor, ringed (thick: detected) and labelled with its heat and fate.
void WriteHeatPng(const DebugInput& in) {
  CameraView view(in.camera, in.result.world_from_camera);
  const Eigen::Vector3f sensor = in.sensor();
  for (const Eigen::Vector3f& p : in.debug().points) {
    const auto [furniture_class, heat] = HeatAt(in.debug(), p);
    if (!furniture_class) {
      view.Dot(p, GreyForDistance((p - sensor).norm()) * 0.5);
      continue;
    }
    view.Dot(p, ClassColour(furniture_class) * (0.3 + 0.7 * std::sqrt(std::min(heat, 1.0f))));
  }
  LabelLayout labels(&view.image());
  for (const DetectionDebug::Hypothesis* hypothesis : DetectedFirst(in.debug())) {
    const DetectionDebug::Hypothesis& h = *hypothesis;
    const auto at = view.Pixel(Eigen::Vector3f(h.x, h.y, 0));
    if (!at) continue;
    const bool detected = h.outcome == HypothesisOutcome::kDetected;
    const cv::Scalar colour = detected ? ClassColour(h.furniture_class) : cv::Scalar(200, 200, 200);
    cv::circle(view.image(), *at, detected ? 8 : 5, colour, detected ? 2 : 1, cv::LINE_AA);
    char text[128];
    if (detected) {
      std::snprintf(text, sizeof(text), "%s %.2f", ClassName(h.furniture_class), h.vote_weight);
    } else {
      std::snprintf(text,
                    sizeof(text),
                    "%s: %s",
                    ClassName(h.furniture_class),
                    DetectionDebug::Describe(h).c_str());
    }
    labels.Draw(text, *at + cv::Point(9, 4), colour, detected ? 0.42 : 0.34);
  }
  Caption(&view.image(),
          "learned heat (brighter: hotter), " + std::to_string(in.debug().hypotheses.size()) +
              " maxima ringed" + LeftOut(labels));
  WritePngAtomically(view.image(), in.Path("heat.png"));
}

// Every fit a hypothesis tried: its model's footprint on the floor, thin grey.
int DrawTriedFits(const DebugInput& in, CameraView* view) {
  int tried = 0;
  for (const DetectionDebug::Hypothesis& h : in.debug().hypotheses) {
    for (const DetectionDebug::Hypothesis::Fit& f : h.fits) {
      if (f.model_index < 0 || f.model_index >= static_cast<int>(in.model.model_shapes.size()))
        continue;
      const ModelShape& shape = in.model.model_shapes[f.model_index];
      const Eigen::Vector3f low(shape.low.x(), shape.low.y(), 0);
      const Eigen::Vector3f high(shape.high.x(), shape.high.y(), 0);
      view->Box(PlanarPose{f.x, f.y, f.yaw}, 0, low, high, cv::Scalar(150, 150, 150), 1);
      ++tried;
    }
  }
  return tried;
}

// Fitted models and every detection's 3-D box over the scan, from the camera,
// with the fits that were tried.
void WriteFittedPng(const DebugInput& in) {
  CameraView view(in.camera, in.result.world_from_camera);
  const Eigen::Vector3f sensor = in.sensor();
  for (const Eigen::Vector3f& p : in.debug().points)
    view.Dot(p, GreyForDistance((p - sensor).norm()));
  for (size_t d = 0; d < in.debug().fitted_points.size(); ++d) {  // none when learned
    const cv::Scalar colour = ClassColour(in.result.detections[d].furniture_class);
    for (const Eigen::Vector3f& p : in.debug().fitted_points[d]) view.Dot(p, colour);
  }
  const int tried = DrawTriedFits(in, &view);
  LabelLayout labels(&view.image());
  for (const Detection& d : in.result.detections) {
    const DetectionBox box = BoxOf(d, in.model);
    const PlanarPose pose{d.x, d.y, d.yaw};
    const cv::Scalar colour = ClassColour(d.furniture_class);
    view.Box(pose, static_cast<float>(d.z), box.low, box.high, colour, 2);
    if (const auto at = view.Pixel(pose.Apply(Eigen::Vector3f(0, 0, box.high.z())))) {
      char text[96];
      std::snprintf(text, sizeof(text), "%s %.2f", ClassName(d.furniture_class), d.score);
      labels.Draw(text, *at + cv::Point(-30, -6), colour);
    }
  }
  Caption(
      &view.image(),
      std::to_string(in.result.detections.size()) +
          (in.result.detections.size() == 1 ? " detection: 3-D box" : " detections: 3-D boxes") +
          (in.debug().fitted_points.empty() ? "" : " and fitted models") + "; " +
          std::to_string(tried) + " fits tried (grey footprints)" + LeftOut(labels));
  WritePngAtomically(view.image(), in.Path("fitted.png"));
}

constexpr int kMinCaptionWidth = 640;  // pixels: the longest caption at its font

// A class's vote heat map, top-down with y up, with its maxima.
// Returns the file's name, or empty when it wrote none.
std::string WriteVotesPng(const DebugInput& in, const DetectionDebug::VoteGrid& grid) {
  if (grid.values.empty()) return "";
  // A class the model has no CAD model of has no map worth a file.
  if (std::find(in.model.model_classes.begin(),
                in.model.model_classes.end(),
                grid.furniture_class) == in.model.model_classes.end())
    return "";
  cv::Mat values(grid.rows, grid.cols, CV_32F, const_cast<float*>(grid.values.data()));
  double high = 0;
  cv::minMaxLoc(values, nullptr, &high);
  // Learned heat is a probability-like 0..1: drawn on that scale, so a weak
  // map looks weak; Hough votes have no scale but their own maximum.
  const double top = grid.learned ? 1.0 : high;
  cv::Mat grey;
  values.convertTo(grey, CV_8U, top > 0 ? 255.0 / top : 0.0);
  cv::Mat flipped, heat;
  cv::flip(grey, flipped, 0);
  cv::applyColorMap(flipped, heat, cv::COLORMAP_INFERNO);
  const double scale = std::clamp(700.0 / std::max(grid.cols, grid.rows), 1.0, 4.0);
  cv::resize(heat, heat, cv::Size(), scale, scale, cv::INTER_NEAREST);
  // Room on the right for the caption: a narrow room's map is wide enough to read.
  if (heat.cols < kMinCaptionWidth)
    cv::copyMakeBorder(heat,
                       heat,
                       0,
                       0,
                       0,
                       kMinCaptionWidth - heat.cols,
                       cv::BORDER_CONSTANT,
                       cv::Scalar(24, 24, 24));
  const double pixels_per_metre = scale / grid.cell_m;
  auto at = [&](double x, double y) {
    return cv::Point(static_cast<int>((x - grid.origin.x()) * pixels_per_metre),
                     heat.rows - static_cast<int>((y - grid.origin.y()) * pixels_per_metre));
  };
  for (size_t i = 0; i < in.debug().points.size(); i += 3) {  // faint scene outline
    const cv::Point p = at(in.debug().points[i].x(), in.debug().points[i].y());
    if (p.x >= 0 && p.y >= 0 && p.x < heat.cols && p.y < heat.rows)
      heat.at<cv::Vec3b>(p) = cv::Vec3b(110, 110, 110);
  }
  cv::circle(heat, at(in.sensor().x(), in.sensor().y()), 5, cv::Scalar(255, 255, 255), cv::FILLED);
  int maxima = 0;
  LabelLayout labels(&heat);
  for (const DetectionDebug::Hypothesis* hypothesis : DetectedFirst(in.debug())) {
    const DetectionDebug::Hypothesis& h = *hypothesis;
    if (h.furniture_class != grid.furniture_class) continue;
    ++maxima;
    const bool detected = h.outcome == HypothesisOutcome::kDetected;
    const cv::Scalar colour = detected ? cv::Scalar(80, 255, 80) : cv::Scalar(200, 200, 200);
    cv::circle(heat, at(h.x, h.y), detected ? 9 : 6, colour, 2, cv::LINE_AA);
    char text[96];
    std::snprintf(
        text, sizeof(text), "%.3g %s", h.vote_weight, DetectionDebug::Describe(h).c_str());
    labels.Draw(text, at(h.x, h.y) + cv::Point(10, 4), colour, 0.38);
  }
  char caption[160];
  std::snprintf(caption,
                sizeof(caption),
                "%s %s: max %.3g, threshold %.3g, %d maxima (green: detected)",
                ClassName(grid.furniture_class),
                grid.learned ? "learned heat (0..1)" : "votes",
                high,
                grid.threshold,
                maxima);
  Caption(&heat, caption + LeftOut(labels));
  const std::string name = std::string("votes_") + ClassName(grid.furniture_class) + ".png";
  WritePngAtomically(heat, in.Path(name));
  return name;
}

// What became of a true object in the frame: found (a detection of its
// class within 10 cm, as the report's gallery counts errors), missed (a
// piece of furniture seen at least 25 %, or of unknown visibility, that none
// is near), or neither (clutter, or hardly in view).
enum class TruthFate { kFound, kMissed, kNeither };
TruthFate FateOf(const GroundTruthFootprint& truth, const std::vector<Detection>& detections) {
  if (!truth.furniture_class) return TruthFate::kNeither;
  for (const Detection& d : detections) {
    if (d.furniture_class == truth.furniture_class &&
        std::hypot(d.x - truth.x, d.y - truth.y) <= 0.10)
      return TruthFate::kFound;
  }
  return truth.visibility < 0 || truth.visibility >= 0.25 ? TruthFate::kMissed
                                                          : TruthFate::kNeither;
}

// Top-down: points, ground truth (white found, red missed), detections
// (class colour).
void WriteTopDownPng(const DebugInput& in) {
  Eigen::Vector2f low = in.sensor().head<2>(), high = in.sensor().head<2>();
  for (const Eigen::Vector3f& p : in.debug().points) {
    low = low.cwiseMin(p.head<2>());
    high = high.cwiseMax(p.head<2>());
  }
  for (const GroundTruthFootprint& g : in.ground_truth) {
    low = low.cwiseMin(Eigen::Vector2f(g.x, g.y));
    high = high.cwiseMax(Eigen::Vector2f(g.x, g.y));
  }
  low -= Eigen::Vector2f::Constant(0.5f);
  high += Eigen::Vector2f::Constant(0.5f);
  const double pixels_per_metre = std::clamp(700.0 / (high - low).maxCoeff(), 40.0, 200.0);
  TopDown top(low, high, pixels_per_metre);
  top.Grid();
  for (const Eigen::Vector3f& p : in.debug().points)
    cv::circle(top.image(), top.At(p.x(), p.y()), 0, GreyForDistance(2.5f - p.z() * 1.5f), 1);
  cv::circle(top.image(),
             top.At(in.sensor().x(), in.sensor().y()),
             6,
             cv::Scalar(255, 255, 255),
             cv::FILLED);
  for (const GroundTruthFootprint& g : in.ground_truth) {
    const Eigen::Vector2f half(static_cast<float>(g.width / 2), static_cast<float>(g.depth / 2));
    const TruthFate fate = FateOf(g, in.result.detections);
    const cv::Scalar colour = fate == TruthFate::kMissed  ? cv::Scalar(40, 40, 255)
                              : fate == TruthFate::kFound ? cv::Scalar(255, 255, 255)
                                                          : cv::Scalar(110, 110, 110);
    top.Footprint(
        PlanarPose{g.x, g.y, g.yaw}, -half, half, colour, fate == TruthFate::kMissed ? 2 : 1);
  }
  LabelLayout labels(&top.image());
  for (const Detection& d : in.result.detections) {
    const DetectionBox box = BoxOf(d, in.model);
    const cv::Scalar colour = ClassColour(d.furniture_class);
    top.Footprint(PlanarPose{d.x, d.y, d.yaw}, box.low.head<2>(), box.high.head<2>(), colour, 2);
    char text[64];
    std::snprintf(text, sizeof(text), "%s %.2f", ClassName(d.furniture_class), d.score);
    labels.Draw(text, top.At(d.x, d.y) + cv::Point(6, -6), colour, 0.4);
  }
  // Only a labelled frame has truth to show (a real scan given to detect has none).
  Caption(
      &top.image(),
      in.ground_truth.empty()
          ? "top-down, world frame (1 m grid): detections (class colour), sensor (white dot)" +
                LeftOut(labels)
          : "top-down (1 m grid): detections (class colour); truth: found (white), missed (red), "
            "clutter or hardly seen (grey)" +
                LeftOut(labels));
  WritePngAtomically(top.image(), in.Path("topdown.png"));
}

// Every hypothesis: class, position, votes, candidates, fits, outcome.
void WriteHypothesesJson(const DebugInput& in) {
  nlohmann::ordered_json hypotheses = nlohmann::ordered_json::array();
  for (const DetectionDebug::Hypothesis& h : in.debug().hypotheses) {
    nlohmann::ordered_json candidates = nlohmann::ordered_json::array();
    for (int m : h.candidate_models) candidates.push_back(in.model.model_names[m]);
    nlohmann::ordered_json fits = nlohmann::ordered_json::array();
    for (const DetectionDebug::Hypothesis::Fit& f : h.fits) {
      fits.push_back({{"model", in.model.model_names[f.model_index]},
                      {"x", f.x},
                      {"y", f.y},
                      {"yaw", f.yaw},
                      {"covered_fraction", f.covered_fraction},
                      {"verification", f.verification},
                      {"score", f.score}});
    }
    hypotheses.push_back({{"class", ClassName(h.furniture_class)},
                          {"x", h.x},
                          {"y", h.y},
                          {"vote_weight", h.vote_weight},
                          {"segments", h.segments},
                          {"candidates", candidates},
                          {"fits", fits},
                          {"outcome", OutcomeName(h.outcome)},
                          {"outcome_text", DetectionDebug::Describe(h)}});
  }
  WriteFileAtomically(
      in.Path("hypotheses.json"),
      hypotheses.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

}  // namespace

std::vector<std::string> WriteDetectionDebug(const DetectionResult& result,
                                             const TrainedModel& model,
                                             const CameraIntrinsics& camera,
                                             const std::vector<GroundTruthFootprint>& ground_truth,
                                             const std::string& dir,
                                             const SceneViewLinks& links) {
  MakeDirectories(dir, "debug directory");
  const DebugInput in{result, model, camera, ground_truth, dir};
  const bool learned = LearnedRun(result.debug);
  if (learned) {
    WriteHeatPng(in);  // no segments on the learned path
  } else {
    WriteSegmentsPng(in);
  }
  // A folder used before by the other path keeps no figure of that run.
  std::error_code error;
  std::filesystem::remove(in.Path(learned ? "segments.png" : "heat.png"), error);
  WriteFittedPng(in);
  std::vector<std::string> images = {"fitted.png", "topdown.png"};
  images.push_back(learned ? "heat.png" : "segments.png");
  for (const DetectionDebug::VoteGrid& grid : result.debug.grids) {
    const std::string name = WriteVotesPng(in, grid);
    if (!name.empty()) images.push_back(name);
  }
  WriteTopDownPng(in);
  WriteHypothesesJson(in);
  WriteSceneView(result, model, camera, ground_truth, dir, links);
  return images;
}

}  // namespace furn
