#include "reports/evaluation.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <set>

#include "core/geometry/box_iou.h"
#include "core/util/error.h"

namespace furn {
namespace {

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const double position = q * (values.size() - 1);
  const size_t low = static_cast<size_t>(std::floor(position));
  const size_t high = std::min(values.size() - 1, low + 1);
  return values[low] + (position - low) * (values[high] - values[low]);
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

// Yaw difference in degrees, modulo 360 / symmetry.
double YawErrorDeg(double a, double b, int symmetry) {
  const double period = 2 * M_PI / std::max(1, symmetry);
  double d = std::fmod(std::abs(a - b), period);
  d = std::min(d, period - d);
  return d * 180 / M_PI;
}

enum class Role { kTarget, kIgnore, kAbsent };

struct Matching {
  std::vector<PrPoint> curve;
  std::vector<std::pair<int, int>> counts;  // per curve point: true and false positives so far
  int targets = 0;
  std::vector<int> targets_in_frame, true_positives_in_frame, false_positives_in_frame;
  std::vector<std::pair<const ScoredDetection*, const TruthObject*>> true_positives;
  std::vector<const ScoredDetection*> false_positives;
};

struct Candidate {
  size_t frame;
  const ScoredDetection* detection;
};

// Starts a matching of one class: its targets counted per frame, and its
// detections returned best score first (ties in frame order).
std::vector<Candidate> StartMatching(const std::vector<FrameOutcome>& frames,
                                     FurnitureClass furniture_class,
                                     const std::function<Role(const TruthObject&)>& role,
                                     Matching* result) {
  result->targets_in_frame.assign(frames.size(), 0);
  result->true_positives_in_frame.assign(frames.size(), 0);
  result->false_positives_in_frame.assign(frames.size(), 0);
  std::vector<Candidate> candidates;
  for (size_t f = 0; f < frames.size(); ++f) {
    for (const TruthObject& t : frames[f].truth) {
      result->targets_in_frame[f] +=
          t.furniture_class == furniture_class && role(t) == Role::kTarget;
    }
    result->targets += result->targets_in_frame[f];
    for (const ScoredDetection& d : frames[f].detections) {
      if (d.furniture_class == furniture_class) candidates.push_back({f, &d});
    }
  }
  std::stable_sort(
      candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.detection->score > b.detection->score;
      });
  return candidates;
}

// A detection booked as a true positive of `truth`, or a false one (none),
// with the curve's point after it.
void Book(const Candidate& c, const TruthObject* truth, Matching* result) {
  if (truth != nullptr) {
    ++result->true_positives_in_frame[c.frame];
    result->true_positives.emplace_back(c.detection, truth);
  } else {
    ++result->false_positives_in_frame[c.frame];
    result->false_positives.push_back(c.detection);
  }
  const int tp = static_cast<int>(result->true_positives.size());
  const int fp = static_cast<int>(result->false_positives.size());
  result->curve.push_back({result->targets > 0 ? static_cast<double>(tp) / result->targets : 0,
                           static_cast<double>(tp) / (tp + fp),
                           c.detection->score});
  result->counts.emplace_back(tp, fp);
}

// Protocol B for one class and distance; `role` says how each true object counts.
Matching MatchClass(const std::vector<FrameOutcome>& frames,
                    FurnitureClass furniture_class,
                    double distance,
                    const std::function<Role(const TruthObject&)>& role) {
  Matching result;
  const std::vector<Candidate> candidates = StartMatching(frames, furniture_class, role, &result);
  std::vector<std::vector<bool>> used(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) used[f].assign(frames[f].truth.size(), false);
  for (const Candidate& c : candidates) {
    const FrameOutcome& frame = frames[c.frame];
    int best = -1;
    double best_distance = distance;
    for (size_t k = 0; k < frame.truth.size(); ++k) {
      const TruthObject& t = frame.truth[k];
      if (used[c.frame][k] || t.furniture_class != furniture_class || role(t) == Role::kAbsent)
        continue;
      const double d = std::hypot(t.x - c.detection->x, t.y - c.detection->y);
      if (d <= best_distance) {
        best_distance = d;
        best = static_cast<int>(k);
      }
    }
    if (best >= 0) {
      used[c.frame][best] = true;
      if (role(frame.truth[best]) == Role::kIgnore) continue;  // neither TP nor FP
    }
    Book(c, best >= 0 ? &frame.truth[best] : nullptr, &result);
  }
  return result;
}

// The funnel and the false-positive kinds at 10 cm (see evaluation.h).
void CountLosses(const std::vector<FrameOutcome>& frames,
                 FurnitureClass furniture_class,
                 const Matching& matching,
                 const EvaluationOptions& options,
                 const std::function<Role(const TruthObject&)>& role,
                 std::map<std::string, double>* m) {
  std::set<const TruthObject*> found;
  std::set<const ScoredDetection*> true_positives;
  for (const auto& [d, t] : matching.true_positives) {
    found.insert(t);
    true_positives.insert(d);
  }
  auto count = [&](FunnelStage stage) {
    (*m)[MetricId::Funnel(furniture_class, stage).Name()] += 1;
    (*m)[MetricId::Funnel(std::nullopt, stage).Name()] += 1;
  };
  const double window = options.funnel_window_m;
  for (const FrameOutcome& frame : frames) {
    for (const TruthObject& t : frame.truth) {
      if (t.furniture_class != furniture_class || role(t) != Role::kTarget) continue;
      if (found.count(&t)) {
        count(FunnelStage::kDetected);
        continue;
      }
      count(LostAt(t, frame.maxima, window));
    }
    for (const ScoredDetection& d : frame.detections) {
      if (d.furniture_class != furniture_class || true_positives.count(&d)) continue;
      double same = 1e9, other = 1e9;
      bool ignored_near = false;
      for (const TruthObject& t : frame.truth) {
        if (!t.furniture_class || role(t) == Role::kAbsent) continue;
        const double distance = std::hypot(t.x - d.x, t.y - d.y);
        if (t.furniture_class == furniture_class) {
          same = std::min(same, distance);
          ignored_near |= distance <= 0.10 && role(t) == Role::kIgnore;
        } else if (role(t) == Role::kTarget) {
          other = std::min(other, distance);
        }
      }
      if (ignored_near) continue;  // matched an ignored object: not a false positive
      const FalsePositiveKind kind = same <= 0.10   ? FalsePositiveKind::kDuplicate
                                     : same <= 0.5  ? FalsePositiveKind::kMislocated
                                     : other <= 0.3 ? FalsePositiveKind::kWrongClass
                                                    : FalsePositiveKind::kBackground;
      (*m)[MetricId::FalsePositives(kind).Name()] += 1;
    }
  }
}

}  // namespace

FunnelStage LostAt(const TruthObject& object,
                   const std::vector<HoughMaximum>& maxima,
                   double window_m) {
  bool any_maximum = false, own_class = false;
  HypothesisOutcome furthest = HypothesisOutcome::kNoSupport;
  for (const HoughMaximum& h : maxima) {
    if (std::hypot(h.x - object.x, h.y - object.y) > window_m) continue;
    any_maximum = true;
    if (h.furniture_class != object.furniture_class) continue;
    furthest = own_class ? std::max(furthest, h.outcome) : h.outcome;
    own_class = true;
  }
  if (own_class) return FunnelStageOf(furthest);
  return any_maximum ? FunnelStage::kWrongClassOnly : FunnelStage::kNoMaximum;
}

// How a detection and an object are compared for the IoU metrics.
enum class Overlap { k3d, kBev };

bool HasBox(const OrientedBox& box) {
  return box.size.x() > 0 && box.size.y() > 0 && box.size.z() > 0;
}

// The indoor protocol of SUN RGB-D and ScanNet as mmdetection3d's
// indoor_eval computes it (VOC style): detections of the class in
// descending score; each one's object is the one of its class it overlaps
// most in its frame; at least `threshold` and not yet taken: a true
// positive, else a false one (a second detection of an object is false). An
// "ignore" object overlapped so is neither; absent objects are not there.
Matching MatchClassByIou(const std::vector<FrameOutcome>& frames,
                         FurnitureClass furniture_class,
                         double threshold,
                         Overlap overlap,
                         const std::function<Role(const TruthObject&)>& role) {
  Matching result;
  const std::vector<Candidate> candidates = StartMatching(frames, furniture_class, role, &result);
  std::vector<std::vector<bool>> used(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) used[f].assign(frames[f].truth.size(), false);
  for (const Candidate& c : candidates) {
    const FrameOutcome& frame = frames[c.frame];
    int best = -1;
    double best_iou = 0;
    for (size_t k = 0; k < frame.truth.size(); ++k) {
      const TruthObject& t = frame.truth[k];
      if (t.furniture_class != furniture_class || role(t) == Role::kAbsent) continue;
      const double iou = overlap == Overlap::k3d ? Iou3d(c.detection->box3d, t.box3d)
                                                 : BevIou(c.detection->box3d, t.box3d);
      if (iou > best_iou) {
        best_iou = iou;
        best = static_cast<int>(k);
      }
    }
    const bool overlaps = best >= 0 && best_iou >= threshold;
    if (overlaps && role(frame.truth[best]) == Role::kIgnore) continue;  // neither
    const bool found = overlaps && !used[c.frame][best];
    if (found) used[c.frame][best] = true;
    Book(c, found ? &frame.truth[best] : nullptr, &result);
  }
  return result;
}

double AveragePrecision(const std::vector<PrPoint>& curve) {
  // Precision envelope from the right, then the area over recall steps.
  double ap = 0, previous_recall = 0;
  std::vector<double> envelope(curve.size());
  double best = 0;
  for (size_t i = curve.size(); i-- > 0;) {
    best = std::max(best, curve[i].precision);
    envelope[i] = best;
  }
  for (size_t i = 0; i < curve.size(); ++i) {
    if (curve[i].recall > previous_recall) {
      ap += (curve[i].recall - previous_recall) * envelope[i];
      previous_recall = curve[i].recall;
    }
  }
  return ap;
}

double CalibrationError(const std::vector<CalibrationBin>& bins) {
  int total = 0;
  double sum = 0;
  for (const CalibrationBin& bin : bins) {
    if (bin.detections == 0) continue;
    total += bin.detections;
    sum += std::abs(static_cast<double>(bin.true_positives) - bin.score_sum);
  }
  return total > 0 ? sum / total : std::nan("");
}

double ClassObjectCount(const std::map<std::string, double>& metrics,
                        FurnitureClass furniture_class) {
  double objects = 0;
  for (FunnelStage stage : EnumValues<FunnelStage>()) {
    const double n = MetricOrNan(metrics, MetricId::Funnel(furniture_class, stage));
    if (!std::isnan(n)) objects += n;
  }
  return objects;
}

bool HigherIsBetter(const std::string& metric) { return MetricId::Parse(metric).HigherIsBetter(); }

std::map<std::string, std::map<std::string, int>> ConfusionByName(const EvaluationResult& result) {
  std::map<std::string, std::map<std::string, int>> named;
  for (const auto& [detected, row] : result.confusion) {
    for (const auto& [truth, count] : row)
      named[ClassName(detected)][truth ? ClassName(*truth) : "background"] = count;
  }
  for (const auto& [truth, count] : result.missed) named["missed"][ClassName(truth)] = count;
  return named;
}

namespace {

using RoleOf = std::function<Role(const TruthObject&)>;
using Metrics = std::map<std::string, double>;

// Protocol B: AP per class and distance, mAP over the classes with objects.
void AddDetectionAp(const std::vector<FrameOutcome>& frames,
                    const EvaluationOptions& options,
                    const RoleOf& role,
                    EvaluationResult* result) {
  for (double distance : options.distances_m) {
    double sum = 0;
    int classes = 0;
    for (FurnitureClass c : options.classes) {
      const Matching matching = MatchClass(frames, c, distance, role);
      if (matching.targets == 0) continue;
      const double ap = AveragePrecision(matching.curve);
      result->metrics[MetricId::ClassAp(c, distance).Name()] = ap;
      sum += ap;
      ++classes;
      if (std::abs(distance - 0.10) < 1e-9) {
        result->curves[std::string("B/") + ClassName(c) + "@10cm"] = matching.curve;
      }
    }
    if (classes > 0) result->metrics[MetricId::MeanAp(distance).Name()] = sum / classes;
  }
}

// AP at 3-D and bird's-eye IoU thresholds per class, and their means over
// the classes with objects; only when every object and detection of the
// frames has a 3-D box (a set labelled without heights has none).
void AddIouAp(const std::vector<FrameOutcome>& frames,
              const EvaluationOptions& options,
              const RoleOf& role,
              EvaluationResult* result) {
  for (const FrameOutcome& frame : frames) {
    for (const TruthObject& t : frame.truth)
      if (t.furniture_class && role(t) != Role::kAbsent && !HasBox(t.box3d)) return;
    for (const ScoredDetection& d : frame.detections)
      if (!HasBox(d.box3d)) return;
  }
  for (Overlap overlap : {Overlap::k3d, Overlap::kBev}) {
    for (double threshold : options.iou_thresholds) {
      double sum = 0;
      int classes = 0;
      for (FurnitureClass c : options.classes) {
        const Matching matching = MatchClassByIou(frames, c, threshold, overlap, role);
        if (matching.targets == 0) continue;
        const double ap = AveragePrecision(matching.curve);
        result->metrics[MetricId::IouAp(c, threshold, overlap == Overlap::kBev).Name()] = ap;
        sum += ap;
        ++classes;
      }
      if (classes > 0)
        result->metrics[MetricId::IouAp(std::nullopt, threshold, overlap == Overlap::kBev).Name()] =
            sum / classes;
    }
  }
}

// Frames where a false detection outscores every true one, at 20 cm (a
// frame with only false detections counts): what a user acting on the top
// detection of each frame would get wrong.
double FalseAboveTrue(const std::vector<FrameOutcome>& frames,
                      const EvaluationOptions& options,
                      const RoleOf& role) {
  std::set<const ScoredDetection*> true_at_20;
  for (FurnitureClass c : options.classes) {
    for (const auto& [d, t] : MatchClass(frames, c, 0.20, role).true_positives)
      true_at_20.insert(d);
  }
  int wrong_top = 0;
  for (const FrameOutcome& f : frames) {
    double best_true = -1, best_false = -1;
    for (const ScoredDetection& d : f.detections) {
      if (true_at_20.count(&d) > 0) {
        best_true = std::max(best_true, d.score);
        continue;
      }
      bool ignored_near = false;
      for (const TruthObject& t : f.truth) {
        ignored_near |= t.furniture_class == d.furniture_class && role(t) == Role::kIgnore &&
                        std::hypot(t.x - d.x, t.y - d.y) <= 0.20;
      }
      if (!ignored_near) best_false = std::max(best_false, d.score);
    }
    wrong_top += best_false >= 0 && best_false > best_true;
  }
  return static_cast<double>(wrong_top) / frames.size();
}

// The class's detections at 10 cm into the reliability bins (those that
// matched an ignored object left out).
void AddToCalibration(const std::vector<FrameOutcome>& frames,
                      FurnitureClass c,
                      const Matching& matching,
                      const RoleOf& role,
                      std::vector<CalibrationBin>* bins) {
  const int count = static_cast<int>(bins->size());
  std::set<const ScoredDetection*> true_positives;
  for (const auto& [d, t] : matching.true_positives) true_positives.insert(d);
  for (const FrameOutcome& f : frames) {
    for (const ScoredDetection& d : f.detections) {
      if (d.furniture_class != c) continue;
      const bool tp = true_positives.count(&d) > 0;
      bool ignored_near = false;
      for (const TruthObject& t : f.truth) {
        ignored_near |= t.furniture_class == c && role(t) == Role::kIgnore &&
                        std::hypot(t.x - d.x, t.y - d.y) <= 0.10;
      }
      if (!tp && ignored_near) continue;
      const int b = std::clamp(static_cast<int>(std::floor(d.score * count)), 0, count - 1);
      ++(*bins)[b].detections;
      (*bins)[b].true_positives += tp;
      (*bins)[b].score_sum += d.score;
    }
  }
}

// Per frame, what detect outputs gets wrong at 10 cm: the false detections
// at the operating point and the objects none of its true ones found. (Greedy
// matching by score: a kept detection's match is the same among every
// candidate as among the kept ones, which all score higher.)
void AddFrameErrors(const std::vector<FrameOutcome>& frames,
                    FurnitureClass furniture_class,
                    const Matching& matching,
                    const OperatingPoint& point,
                    std::map<int64_t, std::pair<int, int>>* frame_errors) {
  std::set<const ScoredDetection*> true_positives;
  for (const auto& [d, t] : matching.true_positives) true_positives.insert(d);
  const std::set<const ScoredDetection*> false_positives(matching.false_positives.begin(),
                                                         matching.false_positives.end());
  for (size_t f = 0; f < frames.size(); ++f) {
    int found = 0, wrong = 0;
    for (const ScoredDetection& d : frames[f].detections) {
      if (d.furniture_class != furniture_class || !point.Keeps(furniture_class, d.score)) continue;
      found += true_positives.count(&d) > 0;
      wrong += false_positives.count(&d) > 0;
    }
    std::pair<int, int>& errors = (*frame_errors)[frames[f].frame_id];
    errors.first += wrong;
    errors.second += matching.targets_in_frame[f] - found;
  }
}

// At 10 cm: the funnel, false positives, calibration, per-frame errors,
// pose errors and CAD identification.
void AddLossesAndPoseErrors(const std::vector<FrameOutcome>& frames,
                            const EvaluationOptions& options,
                            const RoleOf& role,
                            EvaluationResult* result) {
  Metrics& m = result->metrics;
  double xy_sum = 0, yaw_sum = 0;
  std::vector<double> yaw_errors, size_errors;
  int tps = 0, identified = 0, identifiable = 0;
  for (const FrameOutcome& f : frames) result->frame_errors[f.frame_id] = {0, 0};
  for (FunnelStage stage : EnumValues<FunnelStage>())
    m[MetricId::Funnel(std::nullopt, stage).Name()] = 0;
  for (FalsePositiveKind kind : EnumValues<FalsePositiveKind>())
    m[MetricId::FalsePositives(kind).Name()] = 0;
  constexpr int kCalibrationBins = 10;
  for (int b = 0; b < kCalibrationBins; ++b) {
    CalibrationBin bin;
    bin.low = static_cast<double>(b) / kCalibrationBins;
    bin.high = static_cast<double>(b + 1) / kCalibrationBins;
    result->calibration.push_back(bin);
  }
  for (FurnitureClass c : options.classes) {
    const Matching matching = MatchClass(frames, c, 0.10, role);
    CountLosses(frames, c, matching, options, role, &m);
    AddToCalibration(frames, c, matching, role, &result->calibration);
    AddFrameErrors(frames, c, matching, options.operating_point, &result->frame_errors);
    for (const auto& [d, t] : matching.true_positives) {
      xy_sum += std::hypot(d->x - t->x, d->y - t->y);
      yaw_sum += YawErrorDeg(d->yaw, t->yaw, d->symmetry);
      yaw_errors.push_back(YawErrorDeg(d->yaw, t->yaw, d->symmetry));
      if (d->width > 0 && t->width > 0 && t->depth > 0) {
        auto relative = [&](double w, double h) {
          return (std::abs(w / t->width - 1) + std::abs(h / t->depth - 1)) / 2;
        };
        size_errors.push_back(std::min(relative(d->width, d->depth), relative(d->depth, d->width)));
      }
      ++tps;
      if (t->seen_in_training) {
        ++identifiable;
        identified += d->model_id == t->model_id;
      }
    }
  }
  if (tps > 0) {
    m[MetricId::Plain(PlainMetric::kXyErrorMean).Name()] = xy_sum / tps;
    m[MetricId::Plain(PlainMetric::kYawErrorMean).Name()] = yaw_sum / tps;
    m[MetricId::Plain(PlainMetric::kYawErrorMedian).Name()] = Median(yaw_errors);
  }
  if (!size_errors.empty())
    m[MetricId::Plain(PlainMetric::kSizeErrorMedian).Name()] = Median(size_errors);
  if (identifiable > 0)
    m[MetricId::Plain(PlainMetric::kCadIdentified).Name()] =
        static_cast<double>(identified) / identifiable;
  const double calibration_error = CalibrationError(result->calibration);
  if (std::isfinite(calibration_error))
    m[MetricId::Plain(PlainMetric::kCalibrationError).Name()] = calibration_error;
}

// centre/<class>/median_m (kCentreErrorVisibility): how near the detections
// come to the objects seen well, whatever their scores.
void AddCentreErrors(const std::vector<FrameOutcome>& frames,
                     const EvaluationOptions& options,
                     const RoleOf& role,
                     Metrics* m) {
  for (FurnitureClass c : options.classes) {
    std::vector<double> errors;
    for (const FrameOutcome& f : frames) {
      for (const TruthObject& t : f.truth) {
        if (t.furniture_class != c || role(t) != Role::kTarget ||
            t.visibility * t.in_view < kCentreErrorVisibility)
          continue;
        double nearest = kCentreErrorReachM;
        for (const ScoredDetection& d : f.detections) {
          if (d.furniture_class != c) continue;
          const double distance = std::hypot(d.x - t.x, d.y - t.y);
          nearest = std::min(nearest, distance);
        }
        errors.push_back(nearest);
      }
    }
    if (!errors.empty()) (*m)[MetricId::CentreErrorMedian(c).Name()] = Median(errors);
  }
}

// Seen and unseen CAD models: the other group's objects become "ignore".
void AddSeenAndUnseen(const std::vector<FrameOutcome>& frames,
                      const EvaluationOptions& options,
                      const RoleOf& role,
                      Metrics* m) {
  for (const bool seen : {true, false}) {
    double sum = 0;
    int classes = 0;
    for (FurnitureClass c : options.classes) {
      const Matching matching = MatchClass(frames, c, 0.10, [&](const TruthObject& t) {
        const Role r = role(t);
        return r == Role::kTarget && t.seen_in_training != seen ? Role::kIgnore : r;
      });
      if (matching.targets == 0) continue;
      sum += AveragePrecision(matching.curve);
      ++classes;
    }
    if (classes > 0) {
      (*m)[MetricId::Plain(seen ? PlainMetric::kMeanApSeen : PlainMetric::kMeanApUnseen).Name()] =
          sum / classes;
    }
  }
}

// Confusion at the operating point, 10 cm: each kept detection against the
// nearest present object, and the target objects no kept detection reached.
void AddConfusion(const std::vector<FrameOutcome>& frames,
                  const EvaluationOptions& options,
                  const RoleOf& role,
                  EvaluationResult* result) {
  constexpr double kConfusionM = 0.10;
  for (const FrameOutcome& f : frames) {
    std::vector<const ScoredDetection*> kept;
    for (const ScoredDetection& d : f.detections) {
      if (options.operating_point.Keeps(d.furniture_class, d.score)) kept.push_back(&d);
    }
    std::set<const ScoredDetection*> taken;
    // The nearest kept detection within reach not yet taken whose class is
    // (or is not) the object's.
    auto nearest = [&](const TruthObject& t, bool own_class) {
      const ScoredDetection* best = nullptr;
      double best_distance = kConfusionM;
      for (const ScoredDetection* d : kept) {
        if ((d->furniture_class == t.furniture_class) != own_class || taken.count(d)) continue;
        const double distance = std::hypot(t.x - d->x, t.y - d->y);
        if (distance <= best_distance) {
          best_distance = distance;
          best = d;
        }
      }
      return best;
    };
    for (const TruthObject& t : f.truth) {
      if (!t.furniture_class || role(t) != Role::kTarget) continue;
      const ScoredDetection* d = nearest(t, true);
      if (d == nullptr) d = nearest(t, false);
      if (d == nullptr) {
        ++result->missed[*t.furniture_class];
        continue;
      }
      taken.insert(d);
      ++result->confusion[d->furniture_class][t.furniture_class];
    }
    for (const ScoredDetection* d : kept) {
      if (taken.count(d)) continue;
      bool near_object = false;
      for (const TruthObject& t : f.truth) {
        near_object |= t.furniture_class && role(t) != Role::kAbsent &&
                       std::hypot(t.x - d->x, t.y - d->y) <= kConfusionM;
      }
      if (near_object) {
        ++result->confusion_extra;
      } else {
        ++result->confusion[d->furniture_class][std::nullopt];
      }
    }
  }
}

// Protocol A for one class at one threshold: TPs, FPs, objects found and
// objects to find.
struct PaperCounts {
  int tp = 0, fp = 0, found = 0, objects = 0;
};
PaperCounts CountPaperMaxima(const std::vector<FrameOutcome>& frames,
                             FurnitureClass c,
                             double threshold,
                             double window_m,
                             const RoleOf& role) {
  PaperCounts counts;
  for (const FrameOutcome& f : frames) {
    std::vector<bool> hit(f.truth.size(), false);
    for (const HoughMaximum& h : f.maxima) {
      if (h.furniture_class != c || h.relative < threshold) continue;
      bool inside = false;
      for (size_t k = 0; k < f.truth.size(); ++k) {
        const TruthObject& o = f.truth[k];
        if (o.furniture_class != c || role(o) == Role::kAbsent) continue;
        if (std::abs(o.x - h.x) <= window_m && std::abs(o.y - h.y) <= window_m) {
          inside = true;
          hit[k] = true;
        }
      }
      inside ? ++counts.tp : ++counts.fp;
    }
    for (size_t k = 0; k < f.truth.size(); ++k) {
      if (f.truth[k].furniture_class != c || role(f.truth[k]) != Role::kTarget) continue;
      ++counts.objects;
      counts.found += hit[k];
    }
  }
  return counts;
}

// Protocol A: maxima in a square window around the objects, threshold swept.
void AddPaperProtocol(const std::vector<FrameOutcome>& frames,
                      const EvaluationOptions& options,
                      const RoleOf& role,
                      EvaluationResult* result) {
  std::vector<double> thresholds = options.paper_thresholds;
  if (thresholds.empty()) {
    for (int k = 0; k <= 20; ++k) thresholds.push_back(k * 0.05);
  }
  for (FurnitureClass c : options.classes) {
    std::vector<PrPoint> curve;
    double best_f1 = 0;
    int class_objects = 0;
    for (double t : thresholds) {
      const PaperCounts counts = CountPaperMaxima(frames, c, t, options.paper_window_m, role);
      class_objects = counts.objects;
      if (class_objects == 0) break;
      const double recall = static_cast<double>(counts.found) / class_objects;
      const double precision = counts.tp + counts.fp > 0
                                   ? static_cast<double>(counts.tp) / (counts.tp + counts.fp)
                                   : 1.0;
      curve.push_back({recall, precision, t});
      if (precision + recall > 0)
        best_f1 = std::max(best_f1, 2 * precision * recall / (precision + recall));
    }
    if (class_objects == 0) continue;
    result->curves[std::string("A/") + ClassName(c)] = curve;
    result->metrics[MetricId::PaperBestF1(c).Name()] = best_f1;
  }
}

void AddLatency(const std::vector<FrameOutcome>& frames, Metrics* m) {
  std::vector<double> totals;
  std::map<DetectionStage, std::vector<double>> stages;
  for (const FrameOutcome& f : frames) {
    totals.push_back(f.total_ms);
    for (const auto& [stage, ms] : f.stage_ms) stages[stage].push_back(ms);
  }
  (*m)[MetricId::Plain(PlainMetric::kLatencyP50).Name()] = Percentile(totals, 0.5);
  (*m)[MetricId::Plain(PlainMetric::kLatencyP90).Name()] = Percentile(totals, 0.9);
  (*m)[MetricId::Plain(PlainMetric::kLatencyP99).Name()] = Percentile(totals, 0.99);
  for (const auto& [stage, values] : stages)
    (*m)[MetricId::StageLatency(stage).Name()] = Percentile(values, 0.5);
}

RoleOf RoleFor(const EvaluationOptions& options) {
  return [&options](const TruthObject& t) {
    if (t.visibility <= 0) return t.seen_by_fused_frames ? Role::kIgnore : Role::kAbsent;
    return t.visibility >= options.min_visibility && t.in_view >= options.min_in_view &&
                   t.distance_m <= options.max_distance_m
               ? Role::kTarget
               : Role::kIgnore;
  };
}

// True and false positives among a class's detections scoring at least
// min_score (every detection for a negative one), from its matching: greedy
// matching in score order makes a detection's fate independent of weaker ones.
std::pair<int, int> CountsAtScore(const Matching& matching, double min_score) {
  std::pair<int, int> counts{0, 0};
  for (size_t i = 0; i < matching.curve.size(); ++i) {
    if (min_score >= 0 && matching.curve[i].threshold < min_score) break;
    counts = matching.counts[i];
  }
  return counts;
}

// A threshold and what the detections at or above it measure.
struct BestF1 {
  double min_score = -1, precision = 0, recall = 0, f1 = 0;
};

// Precision, recall and F1 of tp true and fp false detections among
// `targets` objects (0 where a share is undefined).
BestF1 Measured(double min_score, int tp, int fp, int targets) {
  BestF1 m{min_score,
           tp + fp > 0 ? static_cast<double>(tp) / (tp + fp) : 0,
           targets > 0 ? static_cast<double>(tp) / targets : 0,
           0};
  m.f1 = m.precision + m.recall > 0 ? 2 * m.precision * m.recall / (m.precision + m.recall) : 0;
  return m;
}

// Precision, recall and F1 of the detections at the operating point, per
// class and over every class (counts summed), and false detections per frame.
void AddOperatingPoint(const std::vector<FrameOutcome>& frames,
                       const EvaluationOptions& options,
                       const RoleOf& role,
                       Metrics* m) {
  const OperatingPoint& point = options.operating_point;
  const double distance = point.match_m;
  int all_tp = 0, all_fp = 0, all_targets = 0;
  auto add = [&](std::optional<FurnitureClass> c, int tp, int fp, int targets) {
    const BestF1 measured = Measured(-1, tp, fp, targets);
    if (tp + fp > 0)
      (*m)[MetricId::Operating(c, OperatingMeasure::kPrecision, distance).Name()] =
          measured.precision;
    if (targets > 0) {
      (*m)[MetricId::Operating(c, OperatingMeasure::kRecall, distance).Name()] = measured.recall;
      (*m)[MetricId::Operating(c, OperatingMeasure::kF1, distance).Name()] = measured.f1;
    }
  };
  for (FurnitureClass c : options.classes) {
    const Matching matching = MatchClass(frames, c, distance, role);
    const auto [tp, fp] = CountsAtScore(matching, point.MinScore(c));
    add(c, tp, fp, matching.targets);
    all_tp += tp;
    all_fp += fp;
    all_targets += matching.targets;
  }
  add(std::nullopt, all_tp, all_fp, all_targets);
  (*m)[MetricId::Operating(std::nullopt, OperatingMeasure::kFalsePerFrame, distance).Name()] =
      static_cast<double>(all_fp) / frames.size();
}

// The operating point's F1 plateau: thresholds whose F1 is within this of
// the best are as good (on a few hundred objects one detection moves F1 by
// about 0.003), and the highest of them is chosen. A flat F1 curve then
// yields fewer false detections instead of a threshold at its low end,
// whichever decoding produced the scores.
constexpr double kF1Plateau = 0.01;

// The highest threshold along score-sorted cumulative counts whose F1 is
// within kF1Plateau of the best; a detection scoring as the next one must go
// with it.
BestF1 BestF1Along(const std::vector<PrPoint>& curve,
                   const std::vector<std::pair<int, int>>& counts,
                   int targets) {
  std::vector<BestF1> candidates;  // thresholds a cut may fall after
  double best_f1 = 0;
  for (size_t i = 0; i < curve.size(); ++i) {
    const bool tie_next = i + 1 < curve.size() && curve[i + 1].threshold == curve[i].threshold;
    if (tie_next) continue;
    const auto [tp, fp] = counts[i];
    candidates.push_back(Measured(curve[i].threshold, tp, fp, targets));
    best_f1 = std::max(best_f1, candidates.back().f1);
  }
  for (const BestF1& candidate : candidates) {
    if (best_f1 > 0 && candidate.f1 >= best_f1 - kF1Plateau) return candidate;
  }
  return BestF1{};
}

// Every class's detections in one list: the threshold a class with too few
// objects of its own takes.
BestF1 PooledBestF1(const std::vector<Matching>& matchings) {
  struct Event {
    double score;
    int tp, fp;
  };
  std::vector<Event> events;
  int targets = 0;
  for (const Matching& m : matchings) {
    targets += m.targets;
    std::pair<int, int> previous{0, 0};
    for (size_t i = 0; i < m.curve.size(); ++i) {
      events.push_back({m.curve[i].threshold,
                        m.counts[i].first - previous.first,
                        m.counts[i].second - previous.second});
      previous = m.counts[i];
    }
  }
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return a.score > b.score;
  });
  std::vector<PrPoint> curve;
  std::vector<std::pair<int, int>> counts;
  int tp = 0, fp = 0;
  for (const Event& e : events) {
    tp += e.tp;
    fp += e.fp;
    curve.push_back({0, 0, e.score});
    counts.emplace_back(tp, fp);
  }
  return targets > 0 ? BestF1Along(curve, counts, targets) : BestF1{};
}

}  // namespace

OperatingPoint ChooseOperatingPoint(const std::vector<FrameOutcome>& frames,
                                    const EvaluationOptions& options,
                                    double match_m,
                                    const std::string& chosen_on) {
  OperatingPoint point;
  point.match_m = match_m;
  point.chosen_on = chosen_on;
  const RoleOf role = RoleFor(options);
  std::vector<Matching> matchings;
  for (FurnitureClass c : options.classes)
    matchings.push_back(MatchClass(frames, c, match_m, role));
  const BestF1 pooled = PooledBestF1(matchings);
  for (size_t k = 0; k < options.classes.size(); ++k) {
    const Matching& matching = matchings[k];
    ClassOperatingPoint& entry = point.classes[static_cast<size_t>(options.classes[k])];
    entry.targets = matching.targets;
    BestF1 chosen = matching.targets >= kOwnOperatingPointObjects
                        ? BestF1Along(matching.curve, matching.counts, matching.targets)
                        : BestF1{};
    if (chosen.f1 == 0) {  // too few objects, or never found: the pooled threshold
      const auto [tp, fp] = CountsAtScore(matching, pooled.min_score);
      chosen = Measured(pooled.min_score, tp, fp, matching.targets);
    }
    entry.min_score = chosen.min_score;
    if (matching.targets > 0) {
      entry.precision = chosen.precision;
      entry.recall = chosen.recall;
      entry.f1 = chosen.f1;
    }
  }
  return point;
}

FrameMatch MatchFrame(const FrameOutcome& frame,
                      const EvaluationOptions& options,
                      double distance_m) {
  const std::vector<FrameOutcome> frames = {frame};
  const FrameOutcome& copy = frames.front();
  const RoleOf role = RoleFor(options);
  FrameMatch match;
  match.truth_of_detection.assign(copy.detections.size(), FrameMatch::kMatchedIgnored);
  for (const TruthObject& t : copy.truth)
    match.target.push_back(t.furniture_class.has_value() && role(t) == Role::kTarget);
  for (FurnitureClass c : kAllClasses) {
    const Matching matching = MatchClass(frames, c, distance_m, role);
    for (const auto& [d, t] : matching.true_positives)
      match.truth_of_detection[d - copy.detections.data()] =
          static_cast<int>(t - copy.truth.data());
    for (const ScoredDetection* d : matching.false_positives)
      match.truth_of_detection[d - copy.detections.data()] = FrameMatch::kFalseDetection;
  }
  return match;
}

EvaluationResult EvaluateFrames(const std::vector<FrameOutcome>& frames,
                                const EvaluationOptions& options) {
  Require(!frames.empty(), "evaluation needs at least one frame");
  EvaluationResult result;
  Metrics& m = result.metrics;
  const RoleOf role = RoleFor(options);
  int objects = 0;
  for (const FrameOutcome& f : frames) {
    for (const TruthObject& t : f.truth) objects += t.furniture_class && role(t) == Role::kTarget;
  }
  m[MetricId::Plain(PlainMetric::kFrames).Name()] = static_cast<double>(frames.size());
  m[MetricId::Plain(PlainMetric::kObjects).Name()] = objects;
  AddDetectionAp(frames, options, role, &result);
  AddIouAp(frames, options, role, &result);
  m[MetricId::Plain(PlainMetric::kFalseAboveTrue).Name()] = FalseAboveTrue(frames, options, role);
  AddLossesAndPoseErrors(frames, options, role, &result);
  AddSeenAndUnseen(frames, options, role, &m);
  AddCentreErrors(frames, options, role, &m);
  AddConfusion(frames, options, role, &result);
  if (options.paper_protocol) AddPaperProtocol(frames, options, role, &result);
  AddLatency(frames, &m);
  AddOperatingPoint(frames, options, role, &m);
  return result;
}

}  // namespace furn
