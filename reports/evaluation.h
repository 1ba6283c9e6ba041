// Evaluation protocols A and B of SPEC.md §9 over a set of frames, as pure
// functions of ground truth and detector output.
//
// B (detection): per class and match distance, detections sorted by score are
// matched greedily to the nearest unmatched true object of their class within
// the distance. True objects seen below min_visibility, or whose reference
// point lies beyond the detector's range, are "ignore": neither TP nor FN, and
// matching one is not an FP. AP is all-point interpolated (the area under the
// precision envelope); mAP averages the classes with at least one object to
// find. For TPs: xy error, yaw error modulo the model's rotational symmetry
// (mean and median), the footprint's relative size error (median; detections
// that give a footprint), and whether the CAD model was identified. Metrics are also computed over
// objects whose CAD model was seen in training and over unseen ones.
//
// A (the paper's): per class, a local maximum within a square window (5 cm)
// of a true object's reference point is a TP; other maxima are FPs; objects
// with no maximum in their window are FNs; the relative threshold is swept.
//
//   EvaluationResult result = EvaluateFrames(frames, EvaluationOptions{});
//   MetricOrNan(result.metrics, MetricId::MeanAp(0.10));
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/detector/detector.h"     // HypothesisOutcome
#include "core/geometry/conventions.h"  // OrientedBox
#include "reports/metric_id.h"

namespace furn {

struct TruthObject : FurnitureBox {  // the box in the world frame; footprint 0: unknown
  std::optional<FurnitureClass> furniture_class;  // none: clutter, never a target
  std::string model_id;
  double visibility = 0;         // visible / amodal pixels in this frame
  double distance_m = 0;         // from the camera to the reference point
  bool seen_in_training = true;  // false for evaluation-only CAD models
  // Share of the object's 3-D box inside the camera's view (1: wholly in
  // the frame). `visibility` counts only the pixels in the frame; a long
  // table cut by the image's side is "fully visible" there but half in view.
  double in_view = 1;
  // Fused frames (evaluate --fuse-room-frames): not in this frame's view but
  // seen by another frame fused into its scan, so a detection of it is
  // neither found nor false ("ignore"); unfused, such an object is absent.
  bool seen_by_fused_frames = false;
  // The object's 3-D box in the world (REP 103; size 0: unknown, e.g. a
  // label without a height): what the IoU metrics compare.
  OrientedBox box3d = {};
};

struct ScoredDetection : FurnitureBox {  // footprint when the detector gives one
  FurnitureClass furniture_class = FurnitureClass::kChair;
  std::string model_id;
  double score = 0;
  int symmetry = 1;  // rotational symmetry order of the detected model (1, 2 or 4)
  // The detection's 3-D box in the world (its REP 103 box: the learned
  // footprint or the fitted model's bounds, with a height); size 0: unknown.
  OrientedBox box3d = {};
};

struct HoughMaximum {
  FurnitureClass furniture_class = FurnitureClass::kChair;
  double x = 0, y = 0;
  double relative = 0;  // (value - min) / (max - min) of its class grid
  HypothesisOutcome outcome = HypothesisOutcome::kNoSupport;  // where it stopped
};

struct FrameOutcome {
  int64_t frame_id = 0;
  std::vector<TruthObject> truth;
  std::vector<ScoredDetection> detections;
  std::vector<HoughMaximum> maxima;
  double total_ms = 0;
  std::map<DetectionStage, double> stage_ms;  // every stage but kTotal
};

// centre/<class>/median_m (issue 37's target for tables): over the class's
// target objects seen at least this much (visibility x in_view: the share
// of the whole object the scan shows), the distance from each to the
// nearest detection of its class (any score: how well the detector places
// what it finds, as AP sweeps every detection), or kCentreErrorReachM when
// none is nearer (so the median reads the reach when at most half of them
// were found).
inline constexpr double kCentreErrorVisibility = 0.5;
inline constexpr double kCentreErrorReachM = 0.5;

struct EvaluationOptions {
  // Classes evaluated: every class (one without objects or detections in the
  // frames adds no metric).
  std::vector<FurnitureClass> classes{kAllClasses.begin(), kAllClasses.end()};
  std::vector<double> distances_m = {0.05, 0.10, 0.20};
  // AP at these 3-D and bird's-eye IoUs of the boxes (AP3D/<class>@0.25,
  // APBEV/<class>@0.25), when every object and detection has a 3-D box.
  std::vector<double> iou_thresholds = {0.25, 0.5};
  double min_visibility = 0.25;
  // Objects with less of their box in view (TruthObject::in_view: cut by the
  // image's side) are "ignore" too; 0, the default, keeps them as targets
  // (what every figure so far counted). KITTI calls it truncation.
  double min_in_view = 0;
  double max_distance_m = 3.0;           // objects farther from the camera are "ignore"
  double paper_window_m = 0.05;          // protocol A: half the window's side
  double funnel_window_m = 0.15;         // a maximum this near an object is about it
  std::vector<double> paper_thresholds;  // protocol A sweep; empty: 0, 0.05, .., 1
  // The frames' maxima are the Hough maxima of the project's detector and
  // the paper's protocol A sweeps them. False for detections another
  // program wrote (evaluate --detections), whose maxima are its detections:
  // protocol A is left out (the funnel then tells a missed object with a
  // detection of its class nearby from one with none).
  bool paper_protocol = true;
  // The detections at this operating point (a detector's
  // EffectiveOperatingPoint; empty: every detection) give the op/ metrics,
  // matched at its match_m. AP sweeps every detection regardless.
  OperatingPoint operating_point;
};

struct PrPoint {
  double recall = 0, precision = 0, threshold = 0;
};

// Reliability of the detection score at 10 cm (protocol B): detections with
// a score in [low, high), how many were true positives, and their scores'
// sum. Detections that matched an "ignore" object are left out.
struct CalibrationBin {
  double low = 0, high = 0;
  int detections = 0, true_positives = 0;
  double score_sum = 0;
};

struct EvaluationResult {
  // Flat, named metrics (see EvaluateFrames); what runs store and compare.
  std::map<std::string, double> metrics;
  // PR curves: "B/<class>@10cm" (by score) and "A/<class>" (by threshold).
  std::map<std::string, std::vector<PrPoint>> curves;
  // Confusion at the operating point (what detect outputs), 10 cm, each
  // object to find counted once: as the class of the kept detection that
  // took it (its own class's nearest, else another class's nearest; a
  // detection takes one object), counts[detected][true], or in `missed`
  // when none lies within 10 cm. counts[detected][none]: kept detections
  // near no object (background). `confusion_extra`: the other kept
  // detections (a second one on an object, one on an ignored object).
  std::map<FurnitureClass, std::map<std::optional<FurnitureClass>, int>> confusion;
  std::map<FurnitureClass, int> missed;
  int confusion_extra = 0;
  // Per frame id: false detections and missed objects at 10 cm (protocol B)
  // among the detections at the operating point (what detect outputs).
  std::map<int64_t, std::pair<int, int>> frame_errors;
  // Ten equal bins of score over [0, 1] (scores outside are clamped).
  std::vector<CalibrationBin> calibration;
};

// Protocol B on one frame at `distance_m` (greedy by score within each
// class, objects' roles by `options`): per detection the index of the true
// object it found, kFalseDetection, or kMatchedIgnored (it lies on an object
// too little seen or too far to count: neither true nor false); per true
// object whether it is a target (an object to find).
struct FrameMatch {
  static constexpr int kFalseDetection = -1, kMatchedIgnored = -2;
  std::vector<int> truth_of_detection;
  std::vector<bool> target;
};
FrameMatch MatchFrame(const FrameOutcome& frame,
                      const EvaluationOptions& options,
                      double distance_m);

// The funnel stage of an object no detection found: the furthest stage a
// maximum of its class within window_m of it reached, else kWrongClassOnly
// (maxima of other classes only) or kNoMaximum.
FunnelStage LostAt(const TruthObject& object,
                   const std::vector<HoughMaximum>& maxima,
                   double window_m);

// Expected calibration error of the bins: the detection-weighted mean of
// |true-positive share - mean score|; NaN without detections.
double CalibrationError(const std::vector<CalibrationBin>& bins);

// Where objects are lost (at 10 cm, objects that count as targets): each is
// FunnelStage::kDetected (a TP), else the furthest stage reached by a maximum
// of its class within funnel_window_m of it (FunnelStageOf its outcome;
// kDetectedOffTarget when that maximum's detection lies farther than 10 cm or
// matched another object), kWrongClassOnly (maxima of other classes only) or
// kNoMaximum. Metrics MetricId::Funnel(class or all, stage), counts. False
// positives at 10 cm by kind (MetricId::FalsePositives): duplicate (an object
// of its class within 10 cm, already matched), mislocated (one within 0.5 m),
// wrong class (an object of another class within 0.3 m), background (none).

// Metrics (metric_id.h): at the operating point (options.operating_point,
// its match distance) precision, recall and F1 per class and over every class
// (counts summed), and false detections per frame (MetricId::Operating);
// ClassAp and MeanAp per distance, mAP_seen@10cm and
// mAP_unseen@10cm (when such objects exist), pose errors, cad_identified (TPs
// at 10 cm whose model is the true one, seen models only), latency
// percentiles and per stage, PaperBestF1 per class, calibration_error (when
// there are detections), frames, objects, the funnel and false positives.

EvaluationResult EvaluateFrames(const std::vector<FrameOutcome>& frames,
                                const EvaluationOptions& options);

// Per class, the threshold on the detection score with the best F1 over
// `frames` (matched at match_m, protocol B's roles), with its precision,
// recall and F1 there (the highest threshold whose F1 is within 0.01 of the
// best: a flat F1 curve gives fewer false detections). A class
// with fewer than kOwnOperatingPointObjects objects, or never found, takes
// the threshold of best F1 over every class's detections pooled (none when
// nothing was found at all), measured on its own objects.
inline constexpr int kOwnOperatingPointObjects = 10;
OperatingPoint ChooseOperatingPoint(const std::vector<FrameOutcome>& frames,
                                    const EvaluationOptions& options,
                                    double match_m,
                                    const std::string& chosen_on);

// All-point interpolated average precision of a PR curve sorted by recall.
double AveragePrecision(const std::vector<PrPoint>& curve);

// Objects of a class to find in an evaluation's metrics (its funnel's stages
// summed); 0 when it has none.
double ClassObjectCount(const std::map<std::string, double>& metrics,
                        FurnitureClass furniture_class);

// Whether a higher value of the named metric is better (false for errors
// and latency); InputError for a name that is no metric.
bool HigherIsBetter(const std::string& metric);

// The confusion as JSON: {detected class or "missed": {true class or
// "background": count}}.
std::map<std::string, std::map<std::string, int>> ConfusionByName(const EvaluationResult& result);

}  // namespace furn
