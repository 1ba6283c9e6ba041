// Metric ids: every metric an evaluation stores, typed, with its text name
// (what runs store and baselines, tuning objectives and reports name), its
// unit and whether higher is better, defined in one place. A misspelt name
// is an InputError, never a silent NaN.
//
//   MetricId id = MetricId::ClassAp(FurnitureClass::kTable, 0.10);
//   id.Name();                                  // "AP/table@10cm"
//   MetricId::Parse("mAP@10cm").HigherIsBetter();  // true
//   MetricOrNan(run.metrics, MetricId::MeanAp(0.10));
#pragma once

#include <map>
#include <optional>
#include <string>

#include "core/detector/detector.h"
#include "core/model/furniture_class.h"
#include "core/util/enum_text.h"

namespace furn {

// Where an object was lost (evaluation.h): a hypothesis outcome, or one of
// the stages around them. In the order reports list them.
enum class FunnelStage {
  kDetected,
  kDetectedOffTarget,    // its maximum's detection lies farther than 10 cm or matched another
  kBelowOperatingPoint,  // a candidate below its class's operating point (not in evaluate's runs)
  kSuppressed,
  kLowScore,
  kSeenThrough,
  kLowSeenOccupied,
  kLowVerification,
  kLowCoverage,
  kNoFit,
  kSameSupport,
  kNoSupport,
  kWrongClassOnly,  // only maxima of other classes near it
  kNoMaximum,
};
template <>
struct EnumText<FunnelStage> {
  static constexpr const char* kKind = "funnel stage";
  static constexpr EnumEntry<FunnelStage> kEntries[] = {
      {FunnelStage::kDetected, "detected"},
      {FunnelStage::kDetectedOffTarget, "detected_off_target"},
      {FunnelStage::kBelowOperatingPoint, "below_operating_point"},
      {FunnelStage::kSuppressed, "suppressed"},
      {FunnelStage::kLowScore, "low_score"},
      {FunnelStage::kSeenThrough, "seen_through"},
      {FunnelStage::kLowSeenOccupied, "low_seen_occupied"},
      {FunnelStage::kLowVerification, "low_verification"},
      {FunnelStage::kLowCoverage, "low_coverage"},
      {FunnelStage::kNoFit, "no_fit"},
      {FunnelStage::kSameSupport, "same_support"},
      {FunnelStage::kNoSupport, "no_support"},
      {FunnelStage::kWrongClassOnly, "wrong_class_only"},
      {FunnelStage::kNoMaximum, "no_maximum"},
  };
};
// A stage's name for people: "low coverage" for low_coverage.
std::string FunnelStageWords(FunnelStage stage);

// The stage an object whose nearest maximum of its class stopped at
// `outcome` reached (kDetected: detected off target).
FunnelStage FunnelStageOf(HypothesisOutcome outcome);

// False positives at 10 cm by kind (evaluation.h).
enum class FalsePositiveKind { kDuplicate, kMislocated, kWrongClass, kBackground };
template <>
struct EnumText<FalsePositiveKind> {
  static constexpr const char* kKind = "false positive kind";
  static constexpr EnumEntry<FalsePositiveKind> kEntries[] = {
      {FalsePositiveKind::kDuplicate, "duplicate"},
      {FalsePositiveKind::kMislocated, "mislocated"},
      {FalsePositiveKind::kWrongClass, "wrong_class"},
      {FalsePositiveKind::kBackground, "background"},
  };
};

// What the operating point's detections measure (MetricId::Operating).
enum class OperatingMeasure { kPrecision, kRecall, kF1, kFalsePerFrame };
template <>
struct EnumText<OperatingMeasure> {
  static constexpr const char* kKind = "operating-point measure";
  static constexpr EnumEntry<OperatingMeasure> kEntries[] = {
      {OperatingMeasure::kPrecision, "precision"},
      {OperatingMeasure::kRecall, "recall"},
      {OperatingMeasure::kF1, "f1"},
      {OperatingMeasure::kFalsePerFrame, "false_per_frame"},
  };
};

// The metrics that take no parameter.
enum class PlainMetric {
  kFrames,
  kObjects,
  kMeanApSeen,    // mAP@10cm over objects whose CAD model was trained on
  kMeanApUnseen,  // ... and over the others
  kXyErrorMean,
  kYawErrorMean,
  kYawErrorMedian,
  kSizeErrorMedian,  // footprint: mean of |width| and |depth| relative errors, sides either way
  kCadIdentified,
  kFalseAboveTrue,  // share of frames whose best false detection outscores every true one (20 cm)
  kCalibrationError,
  kLatencyP50,
  kLatencyP90,
  kLatencyP99,
  kFramesWithoutPoints,
  kFramesWithoutFloor,
  kFolds,  // protocol E runs
};

class MetricId {
 public:
  enum class Kind {
    kPlain,
    kMeanAp,
    kClassAp,
    kPaperBestF1,
    kStageLatency,
    kFunnel,
    kFalsePositives,
    kOperating,
    kCentreError,
    kIouAp
  };
  // Crossval runs store each metric's mean plainly, and its spread over the
  // folds and its value with the fixed gates under a prefix.
  enum class Group { kValue, kSpread, kGates };

  static MetricId Plain(PlainMetric metric);
  static MetricId MeanAp(double distance_m);                                   // mAP@10cm
  static MetricId ClassAp(FurnitureClass furniture_class, double distance_m);  // AP/chair@10cm
  static MetricId PaperBestF1(FurnitureClass furniture_class);  // paper/chair/best_f1
  static MetricId StageLatency(DetectionStage stage);           // latency_vote_p50_ms
  // funnel/<class>/<stage>, or funnel/all/<stage> without a class.
  static MetricId Funnel(std::optional<FurnitureClass> furniture_class, FunnelStage stage);
  static MetricId FalsePositives(FalsePositiveKind kind);  // false_positives/<kind>
  // The detections at the operating point, matched at distance_m:
  // op/precision@20cm over every class, op/chair/recall@20cm for one.
  static MetricId Operating(std::optional<FurnitureClass> furniture_class,
                            OperatingMeasure measure,
                            double distance_m);
  // centre/<class>/median_m: the median centre error of the class's objects
  // seen at least half (reports/evaluation.h, kCentreErrorVisibility).
  static MetricId CentreErrorMedian(FurnitureClass furniture_class);
  // AP at a box IoU (the SUN RGB-D / ScanNet protocol): AP3D/chair@0.25 of
  // the 3-D boxes, APBEV/chair@0.25 of their footprints, mAP3D@0.5 and
  // mAPBEV@0.5 over the classes (none: over the classes).
  static MetricId IouAp(std::optional<FurnitureClass> furniture_class, double iou, bool bev);

  // The metric of this name; InputError naming it and what names look like.
  static MetricId Parse(const std::string& name);
  static std::optional<MetricId> TryParse(const std::string& name);
  static std::optional<MetricId> ParseIouAp(const std::string& name);

  MetricId InGroup(Group group) const;
  std::string Name() const;
  bool HigherIsBetter() const;
  // "", "m", "deg", "ms" or "count": how reports print it.
  const char* Unit() const;

  Kind kind() const { return kind_; }
  // The class a per-class metric is about (none: over every class).
  std::optional<FurnitureClass> furniture_class() const { return class_; }
  Group group() const { return group_; }
  // The match distance of an AP, operating-point or centre metric (m).
  double distance_m() const { return centimetres_ / 100.0; }
  // The IoU threshold of an IoU AP, and whether it is of the footprints.
  double iou() const { return iou_percent_ / 100.0; }
  bool bev() const { return bev_; }
  bool operator==(const MetricId& other) const { return Name() == other.Name(); }

 private:
  MetricId() = default;
  Kind kind_ = Kind::kPlain;
  Group group_ = Group::kValue;
  PlainMetric plain_ = PlainMetric::kFrames;
  std::optional<FurnitureClass> class_;
  int centimetres_ = 0;
  DetectionStage stage_ = DetectionStage::kTotal;
  FunnelStage funnel_ = FunnelStage::kDetected;
  FalsePositiveKind false_positive_ = FalsePositiveKind::kBackground;
  OperatingMeasure measure_ = OperatingMeasure::kPrecision;
  int iou_percent_ = 0;
  bool bev_ = false;
};

// The metric's value, or NaN when a run lacks it (e.g. AP of a class that
// had no objects).
double MetricOrNan(const std::map<std::string, double>& metrics, const MetricId& id);
// The match distance (m) a run's operating-point metrics were measured at
// (evaluate --op-match), kOperatingMatchM when it has none.
double OperatingMatchOf(const std::map<std::string, double>& metrics);

}  // namespace furn
