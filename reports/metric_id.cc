#include "reports/metric_id.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>

#include "core/util/error.h"

namespace furn {
namespace {

struct PlainEntry {
  PlainMetric metric;
  const char* name;
  const char* unit;
  bool higher_is_better;
};

// Every parameterless metric: name, unit, direction.
constexpr PlainEntry kPlainMetrics[] = {
    {PlainMetric::kFrames, "frames", "count", true},
    {PlainMetric::kObjects, "objects", "count", true},
    {PlainMetric::kMeanApSeen, "mAP_seen@10cm", "", true},
    {PlainMetric::kMeanApUnseen, "mAP_unseen@10cm", "", true},
    {PlainMetric::kXyErrorMean, "xy_error_mean_m", "m", false},
    {PlainMetric::kYawErrorMean, "yaw_error_mean_deg", "deg", false},
    {PlainMetric::kYawErrorMedian, "yaw_error_median_deg", "deg", false},
    {PlainMetric::kSizeErrorMedian, "size_error_median", "", false},
    {PlainMetric::kCadIdentified, "cad_identified", "", true},
    {PlainMetric::kFalseAboveTrue, "false_above_true_error@20cm", "", false},
    {PlainMetric::kCalibrationError, "calibration_error", "", false},
    {PlainMetric::kLatencyP50, "latency_p50_ms", "ms", false},
    {PlainMetric::kLatencyP90, "latency_p90_ms", "ms", false},
    {PlainMetric::kLatencyP99, "latency_p99_ms", "ms", false},
    {PlainMetric::kFramesWithoutPoints, "frames_without_points", "count", false},
    {PlainMetric::kFramesWithoutFloor, "frames_without_floor", "count", false},
    {PlainMetric::kFolds, "folds", "count", true},
};

const PlainEntry& EntryOf(PlainMetric metric) {
  for (const PlainEntry& entry : kPlainMetrics) {
    if (entry.metric == metric) return entry;
  }
  throw std::logic_error("plain metric without an entry");
}

constexpr const char* kGroupPrefix[] = {"", "spread/", "gates/"};

// "10cm" -> 10; nullopt for anything else.
std::optional<int> ParseCentimetres(const std::string& text) {
  if (text.size() < 3 || text.compare(text.size() - 2, 2, "cm") != 0) return std::nullopt;
  const std::string digits = text.substr(0, text.size() - 2);
  if (digits.empty() || digits.size() > 3 ||
      digits.find_first_not_of("0123456789") != std::string::npos)
    return std::nullopt;
  return std::stoi(digits);
}

bool StartsWith(const std::string& text, const char* prefix, std::string* rest) {
  const std::string p(prefix);
  if (text.compare(0, p.size(), p) != 0) return false;
  *rest = text.substr(p.size());
  return true;
}

}  // namespace

std::string FunnelStageWords(FunnelStage stage) {
  std::string words = EnumName(stage);
  std::replace(words.begin(), words.end(), '_', ' ');
  return words;
}

FunnelStage FunnelStageOf(HypothesisOutcome outcome) {
  // Derived, not mirrored: every stage a hypothesis can stop at is the
  // funnel stage of its name (EveryOutcomeHasItsFunnelStage checks each);
  // a maximum that became a detection but matched no object of its class
  // within 10 cm is "detected off target".
  if (outcome == HypothesisOutcome::kDetected) return FunnelStage::kDetectedOffTarget;
  return ParseEnum<FunnelStage>(EnumName(outcome));
}

MetricId MetricId::Plain(PlainMetric metric) {
  MetricId id;
  id.kind_ = Kind::kPlain;
  id.plain_ = metric;
  return id;
}

MetricId MetricId::MeanAp(double distance_m) {
  MetricId id;
  id.kind_ = Kind::kMeanAp;
  id.centimetres_ = static_cast<int>(std::lround(distance_m * 100));
  return id;
}

MetricId MetricId::ClassAp(FurnitureClass furniture_class, double distance_m) {
  MetricId id = MeanAp(distance_m);
  id.kind_ = Kind::kClassAp;
  id.class_ = furniture_class;
  return id;
}

MetricId MetricId::PaperBestF1(FurnitureClass furniture_class) {
  MetricId id;
  id.kind_ = Kind::kPaperBestF1;
  id.class_ = furniture_class;
  return id;
}

MetricId MetricId::StageLatency(DetectionStage stage) {
  MetricId id;
  id.kind_ = Kind::kStageLatency;
  id.stage_ = stage;
  return id;
}

MetricId MetricId::Funnel(std::optional<FurnitureClass> furniture_class, FunnelStage stage) {
  MetricId id;
  id.kind_ = Kind::kFunnel;
  id.class_ = furniture_class;
  id.funnel_ = stage;
  return id;
}

MetricId MetricId::FalsePositives(FalsePositiveKind kind) {
  MetricId id;
  id.kind_ = Kind::kFalsePositives;
  id.false_positive_ = kind;
  return id;
}

MetricId MetricId::Operating(std::optional<FurnitureClass> furniture_class,
                             OperatingMeasure measure,
                             double distance_m) {
  MetricId id = MeanAp(distance_m);
  id.kind_ = Kind::kOperating;
  id.class_ = furniture_class;
  id.measure_ = measure;
  return id;
}

MetricId MetricId::CentreErrorMedian(FurnitureClass furniture_class) {
  MetricId id;
  id.kind_ = Kind::kCentreError;
  id.class_ = furniture_class;
  return id;
}

MetricId MetricId::IouAp(std::optional<FurnitureClass> furniture_class, double iou, bool bev) {
  MetricId id;
  id.kind_ = Kind::kIouAp;
  id.class_ = furniture_class;
  id.iou_percent_ = static_cast<int>(std::lround(iou * 100));
  id.bev_ = bev;
  return id;
}

MetricId MetricId::InGroup(Group group) const {
  MetricId id = *this;
  id.group_ = group;
  return id;
}

std::string MetricId::Name() const {
  std::string name = kGroupPrefix[static_cast<int>(group_)];
  const std::string cm = std::to_string(centimetres_) + "cm";
  switch (kind_) {
    case Kind::kPlain:
      return name + EntryOf(plain_).name;
    case Kind::kMeanAp:
      return name + "mAP@" + cm;
    case Kind::kClassAp:
      return name + "AP/" + ClassName(*class_) + "@" + cm;
    case Kind::kPaperBestF1:
      return name + "paper/" + ClassName(*class_) + "/best_f1";
    case Kind::kStageLatency:
      return name + "latency_" + EnumName(stage_) + "_p50_ms";
    case Kind::kFunnel:
      return name + "funnel/" + (class_ ? ClassName(*class_) : "all") + "/" + EnumName(funnel_);
    case Kind::kFalsePositives:
      return name + "false_positives/" + EnumName(false_positive_);
    case Kind::kOperating:
      return name + "op/" + (class_ ? std::string(ClassName(*class_)) + "/" : "") +
             EnumName(measure_) + "@" + cm;
    case Kind::kCentreError:
      return name + "centre/" + ClassName(*class_) + "/median_m";
    case Kind::kIouAp: {
      char iou[16];
      std::snprintf(iou, sizeof(iou), "@%d.%02d", iou_percent_ / 100, iou_percent_ % 100);
      const std::string kind = bev_ ? "BEV" : "3D";
      return name + (class_ ? "AP" + kind + "/" + ClassName(*class_) : "mAP" + kind) + iou;
    }
  }
  throw std::logic_error("metric without a name");
}

std::optional<MetricId> MetricId::TryParse(const std::string& full) {
  std::string name = full, rest;
  Group group = Group::kValue;
  if (StartsWith(full, "spread/", &rest)) {
    group = Group::kSpread;
    name = rest;
  } else if (StartsWith(full, "gates/", &rest)) {
    group = Group::kGates;
    name = rest;
  }
  std::optional<MetricId> id;
  for (const PlainEntry& entry : kPlainMetrics) {
    if (name == entry.name) id = Plain(entry.metric);
  }
  const size_t at = name.find('@');
  if (!id && StartsWith(name, "mAP@", &rest)) {
    if (const auto cm = ParseCentimetres(rest)) id = MeanAp(*cm / 100.0);
  } else if (!id && StartsWith(name, "AP/", &rest) && at != std::string::npos) {
    const auto c = FurnitureClassNamed(name.substr(3, at - 3));
    const auto cm = ParseCentimetres(name.substr(at + 1));
    if (c && cm) id = ClassAp(*c, *cm / 100.0);
  } else if (!id && StartsWith(name, "paper/", &rest) && rest.size() > 8 &&
             rest.compare(rest.size() - 8, 8, "/best_f1") == 0) {
    if (const auto c = FurnitureClassNamed(rest.substr(0, rest.size() - 8))) id = PaperBestF1(*c);
  } else if (!id && StartsWith(name, "latency_", &rest) && rest.size() > 7 &&
             rest.compare(rest.size() - 7, 7, "_p50_ms") == 0) {
    if (const auto stage = TryParseEnum<DetectionStage>(rest.substr(0, rest.size() - 7)))
      id = StageLatency(*stage);
  } else if (!id && StartsWith(name, "funnel/", &rest) && rest.find('/') != std::string::npos) {
    const std::string who = rest.substr(0, rest.find('/'));
    const auto stage = TryParseEnum<FunnelStage>(rest.substr(rest.find('/') + 1));
    const auto c = FurnitureClassNamed(who);
    if (stage && (c || who == "all")) id = Funnel(c, *stage);
  } else if (!id && StartsWith(name, "false_positives/", &rest)) {
    if (const auto kind = TryParseEnum<FalsePositiveKind>(rest)) id = FalsePositives(*kind);
  } else if (!id && StartsWith(name, "op/", &rest) && rest.find('@') != std::string::npos) {
    const auto cm = ParseCentimetres(rest.substr(rest.find('@') + 1));
    std::string what = rest.substr(0, rest.find('@'));
    std::optional<FurnitureClass> c;
    if (const size_t slash = what.find('/'); slash != std::string::npos) {
      c = FurnitureClassNamed(what.substr(0, slash));
      what = c ? what.substr(slash + 1) : "";
    }
    const auto measure = TryParseEnum<OperatingMeasure>(what);
    if (cm && measure) id = Operating(c, *measure, *cm / 100.0);
  } else if (!id && StartsWith(name, "centre/", &rest) && rest.size() > 9 &&
             rest.compare(rest.size() - 9, 9, "/median_m") == 0) {
    if (const auto c = FurnitureClassNamed(rest.substr(0, rest.size() - 9)))
      id = CentreErrorMedian(*c);
  }
  if (!id) id = ParseIouAp(name);
  if (id) id->group_ = group;
  return id;
}

// AP3D/<class>@0.25, APBEV/<class>@0.5, mAP3D@0.25, mAPBEV@0.5.
std::optional<MetricId> MetricId::ParseIouAp(const std::string& name) {
  const size_t at = name.find('@');
  if (at == std::string::npos || name.size() - at != 5 || name.compare(at + 2, 1, ".") != 0 ||
      !std::isdigit(static_cast<unsigned char>(name[at + 1])) ||
      !std::isdigit(static_cast<unsigned char>(name[at + 3])) ||
      !std::isdigit(static_cast<unsigned char>(name[at + 4])))
    return std::nullopt;
  const int percent = (name[at + 1] - '0') * 100 + (name[at + 3] - '0') * 10 + (name[at + 4] - '0');
  if (percent < 1 || percent > 100) return std::nullopt;
  const std::string head = name.substr(0, at);
  for (const bool bev : {false, true}) {
    const std::string kind = bev ? "BEV" : "3D";
    if (head == "mAP" + kind) return IouAp(std::nullopt, percent / 100.0, bev);
    std::string rest;
    if (StartsWith(head, ("AP" + kind + "/").c_str(), &rest)) {
      if (const auto c = FurnitureClassNamed(rest)) return IouAp(*c, percent / 100.0, bev);
    }
  }
  return std::nullopt;
}

MetricId MetricId::Parse(const std::string& name) {
  if (const std::optional<MetricId> id = TryParse(name)) return *id;
  throw InputError(
      "unknown metric '" + name +
      "' (e.g. mAP@10cm, AP/chair@20cm, xy_error_mean_m, latency_p50_ms, "
      "paper/table/best_f1, funnel/all/no_maximum, op/precision@20cm, centre/table/median_m, "
      "AP3D/chair@0.25, mAPBEV@0.50)");
}

bool MetricId::HigherIsBetter() const {
  switch (kind_) {
    case Kind::kPlain:
      return EntryOf(plain_).higher_is_better;
    case Kind::kMeanAp:
    case Kind::kClassAp:
    case Kind::kPaperBestF1:
    case Kind::kIouAp:
      return true;
    case Kind::kStageLatency:
    case Kind::kFalsePositives:
      return false;
    case Kind::kFunnel:
      return funnel_ == FunnelStage::kDetected;
    case Kind::kOperating:
      return measure_ != OperatingMeasure::kFalsePerFrame;
    case Kind::kCentreError:
      return false;
  }
  return true;
}

const char* MetricId::Unit() const {
  switch (kind_) {
    case Kind::kPlain:
      return EntryOf(plain_).unit;
    case Kind::kStageLatency:
      return "ms";
    case Kind::kCentreError:
      return "m";
    case Kind::kFunnel:
    case Kind::kFalsePositives:
      return "count";
    default:
      return "";
  }
}

double MetricOrNan(const std::map<std::string, double>& metrics, const MetricId& id) {
  const auto it = metrics.find(id.Name());
  return it == metrics.end() ? std::nan("") : it->second;
}

double OperatingMatchOf(const std::map<std::string, double>& metrics) {
  for (const auto& [name, value] : metrics) {
    const std::optional<MetricId> id = MetricId::TryParse(name);
    if (id && id->kind() == MetricId::Kind::kOperating && id->group() == MetricId::Group::kValue)
      return id->distance_m();
  }
  return kOperatingMatchM;
}

}  // namespace furn
