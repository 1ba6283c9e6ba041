#include "reports/evaluation.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <set>

#include "core/error.h"

namespace furn {
namespace {

std::string CentimetreName(double metres) {
  return std::to_string(static_cast<int>(std::lround(metres * 100))) + "cm";
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const double position = q * (values.size() - 1);
  const size_t low = static_cast<size_t>(std::floor(position));
  const size_t high = std::min(values.size() - 1, low + 1);
  return values[low] + (position - low) * (values[high] - values[low]);
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
  int targets = 0;
  std::vector<int> targets_in_frame, true_positives_in_frame, false_positives_in_frame;
  std::vector<std::pair<const ScoredDetection*, const TruthObject*>> true_positives;
};

// Protocol B for one class and distance; `role` says how each true object counts.
Matching MatchClass(const std::vector<FrameOutcome>& frames,
                    const std::string& furniture_class,
                    double distance,
                    const std::function<Role(const TruthObject&)>& role) {
  Matching result;
  result.targets_in_frame.assign(frames.size(), 0);
  result.true_positives_in_frame.assign(frames.size(), 0);
  result.false_positives_in_frame.assign(frames.size(), 0);
  struct Candidate {
    double score;
    size_t frame;
    const ScoredDetection* detection;
  };
  std::vector<Candidate> candidates;
  for (size_t f = 0; f < frames.size(); ++f) {
    for (const TruthObject& t : frames[f].truth) {
      result.targets_in_frame[f] +=
          t.furniture_class == furniture_class && role(t) == Role::kTarget;
    }
    result.targets += result.targets_in_frame[f];
    for (const ScoredDetection& d : frames[f].detections) {
      if (d.furniture_class == furniture_class) candidates.push_back({d.score, f, &d});
    }
  }
  std::stable_sort(candidates.begin(),
                   candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  std::vector<std::vector<bool>> used(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) used[f].assign(frames[f].truth.size(), false);
  int tp = 0, fp = 0;
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
      ++tp;
      ++result.true_positives_in_frame[c.frame];
      result.true_positives.emplace_back(c.detection, &frame.truth[best]);
    } else {
      ++fp;
      ++result.false_positives_in_frame[c.frame];
    }
    result.curve.push_back({result.targets > 0 ? static_cast<double>(tp) / result.targets : 0,
                            static_cast<double>(tp) / (tp + fp),
                            c.score});
  }
  return result;
}

// The funnel and the false-positive kinds at 10 cm (see evaluation.h).
void CountLosses(const std::vector<FrameOutcome>& frames,
                 const std::string& furniture_class,
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
  auto count = [&](const std::string& stage) {
    (*m)["funnel/" + furniture_class + "/" + stage] += 1;
    (*m)["funnel/all/" + stage] += 1;
  };
  const double window = options.funnel_window_m;
  for (const FrameOutcome& frame : frames) {
    for (const TruthObject& t : frame.truth) {
      if (t.furniture_class != furniture_class || role(t) != Role::kTarget) continue;
      if (found.count(&t)) {
        count("detected");
        continue;
      }
      bool any_maximum = false, own_class = false;
      HypothesisOutcome furthest = HypothesisOutcome::kNoSupport;
      for (const HoughMaximum& h : frame.maxima) {
        if (std::hypot(h.x - t.x, h.y - t.y) > window) continue;
        any_maximum = true;
        if (h.furniture_class != furniture_class) continue;
        furthest = own_class ? std::max(furthest, h.outcome) : h.outcome;
        own_class = true;
      }
      if (!own_class) {
        count(any_maximum ? "wrong_class_only" : "no_maximum");
      } else if (furthest == HypothesisOutcome::kDetected) {
        count("detected_off_target");
      } else {
        count(OutcomeName(furthest));
      }
    }
    for (const ScoredDetection& d : frame.detections) {
      if (d.furniture_class != furniture_class || true_positives.count(&d)) continue;
      double same = 1e9, other = 1e9;
      bool ignored_near = false;
      for (const TruthObject& t : frame.truth) {
        if (t.furniture_class.empty() || role(t) == Role::kAbsent) continue;
        const double distance = std::hypot(t.x - d.x, t.y - d.y);
        if (t.furniture_class == furniture_class) {
          same = std::min(same, distance);
          ignored_near |= distance <= 0.10 && role(t) == Role::kIgnore;
        } else if (role(t) == Role::kTarget) {
          other = std::min(other, distance);
        }
      }
      if (ignored_near) continue;  // matched an ignored object: not a false positive
      const char* kind = same <= 0.10   ? "duplicate"
                         : same <= 0.5  ? "mislocated"
                         : other <= 0.3 ? "wrong_class"
                                        : "background";
      (*m)[std::string("false_positives/") + kind] += 1;
    }
  }
}

}  // namespace

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

bool HigherIsBetter(const std::string& metric) {
  return metric.find("error") == std::string::npos && metric.rfind("latency", 0) != 0;
}

double MetricOrNan(const std::map<std::string, double>& metrics, const std::string& name) {
  const auto it = metrics.find(name);
  return it == metrics.end() ? std::nan("") : it->second;
}

EvaluationResult EvaluateFrames(const std::vector<FrameOutcome>& frames,
                                const EvaluationOptions& options) {
  Require(!frames.empty(), "evaluation needs at least one frame");
  EvaluationResult result;
  std::map<std::string, double>& m = result.metrics;
  auto in_reach = [&](const TruthObject& t) {
    return t.visibility >= options.min_visibility && t.distance_m <= options.max_distance_m;
  };
  auto all_objects = [&](const TruthObject& t) {
    if (t.visibility <= 0) return Role::kAbsent;
    return in_reach(t) ? Role::kTarget : Role::kIgnore;
  };
  int objects = 0;
  for (const FrameOutcome& f : frames) {
    for (const TruthObject& t : f.truth)
      objects += !t.furniture_class.empty() && all_objects(t) == Role::kTarget;
  }
  m["frames"] = static_cast<double>(frames.size());
  m["objects"] = objects;

  for (double distance : options.distances_m) {
    double sum = 0;
    int classes = 0;
    for (const std::string& c : options.classes) {
      const Matching matching = MatchClass(frames, c, distance, all_objects);
      if (matching.targets == 0) continue;
      const double ap = AveragePrecision(matching.curve);
      m["AP/" + c + "@" + CentimetreName(distance)] = ap;
      sum += ap;
      ++classes;
      if (std::abs(distance - 0.10) < 1e-9) {
        result.curves["B/" + c + "@10cm"] = matching.curve;
      }
    }
    if (classes > 0) m["mAP@" + CentimetreName(distance)] = sum / classes;
  }

  // Frames where a false detection outscores every true one, at 20 cm (a
  // frame with only false detections counts): what a user acting on the
  // top detection of each frame would get wrong.
  {
    std::set<const ScoredDetection*> true_at_20;
    for (const std::string& c : options.classes) {
      for (const auto& [d, t] : MatchClass(frames, c, 0.20, all_objects).true_positives)
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
          ignored_near |= t.furniture_class == d.furniture_class &&
                          all_objects(t) == Role::kIgnore &&
                          std::hypot(t.x - d.x, t.y - d.y) <= 0.20;
        }
        if (!ignored_near) best_false = std::max(best_false, d.score);
      }
      wrong_top += best_false >= 0 && best_false > best_true;
    }
    m["false_above_true_error@20cm"] = static_cast<double>(wrong_top) / frames.size();
  }

  // Pose errors, CAD identification and per-frame errors at 10 cm.
  double xy_sum = 0, yaw_sum = 0;
  int tps = 0, identified = 0, identifiable = 0;
  for (const FrameOutcome& f : frames) result.frame_errors[f.frame_id] = {0, 0};
  for (const char* stage : kFunnelStages) m[std::string("funnel/all/") + stage] = 0;
  for (const char* kind : kFalsePositiveKinds) m[std::string("false_positives/") + kind] = 0;
  constexpr int kCalibrationBins = 10;
  for (int b = 0; b < kCalibrationBins; ++b) {
    CalibrationBin bin;
    bin.low = static_cast<double>(b) / kCalibrationBins;
    bin.high = static_cast<double>(b + 1) / kCalibrationBins;
    result.calibration.push_back(bin);
  }
  for (const std::string& c : options.classes) {
    const Matching matching = MatchClass(frames, c, 0.10, all_objects);
    CountLosses(frames, c, matching, options, all_objects, &m);
    std::set<const ScoredDetection*> true_positives;
    for (const auto& [d, t] : matching.true_positives) true_positives.insert(d);
    for (const FrameOutcome& f : frames) {
      for (const ScoredDetection& d : f.detections) {
        if (d.furniture_class != c) continue;
        const bool tp = true_positives.count(&d) > 0;
        bool ignored_near = false;
        for (const TruthObject& t : f.truth) {
          ignored_near |= t.furniture_class == c && all_objects(t) == Role::kIgnore &&
                          std::hypot(t.x - d.x, t.y - d.y) <= 0.10;
        }
        if (!tp && ignored_near) continue;
        const int b = std::clamp(
            static_cast<int>(std::floor(d.score * kCalibrationBins)), 0, kCalibrationBins - 1);
        ++result.calibration[b].detections;
        result.calibration[b].true_positives += tp;
        result.calibration[b].score_sum += d.score;
      }
    }
    for (size_t f = 0; f < frames.size(); ++f) {
      std::pair<int, int>& errors = result.frame_errors[frames[f].frame_id];
      errors.first += matching.false_positives_in_frame[f];
      errors.second += matching.targets_in_frame[f] - matching.true_positives_in_frame[f];
    }
    for (const auto& [d, t] : matching.true_positives) {
      xy_sum += std::hypot(d->x - t->x, d->y - t->y);
      yaw_sum += YawErrorDeg(d->yaw, t->yaw, d->symmetry);
      ++tps;
      if (t->seen_in_training) {
        ++identifiable;
        identified += d->model_id == t->model_id;
      }
    }
  }
  if (tps > 0) {
    m["xy_error_mean_m"] = xy_sum / tps;
    m["yaw_error_mean_deg"] = yaw_sum / tps;
  }
  if (identifiable > 0) m["cad_identified"] = static_cast<double>(identified) / identifiable;
  const double calibration_error = CalibrationError(result.calibration);
  if (std::isfinite(calibration_error)) m["calibration_error"] = calibration_error;

  // Seen and unseen CAD models: the other group's objects become "ignore".
  for (const bool seen : {true, false}) {
    double sum = 0;
    int classes = 0;
    for (const std::string& c : options.classes) {
      const Matching matching = MatchClass(frames, c, 0.10, [&](const TruthObject& t) {
        const Role role = all_objects(t);
        return role == Role::kTarget && t.seen_in_training != seen ? Role::kIgnore : role;
      });
      if (matching.targets == 0) continue;
      sum += AveragePrecision(matching.curve);
      ++classes;
    }
    if (classes > 0) m[seen ? "mAP_seen@10cm" : "mAP_unseen@10cm"] = sum / classes;
  }

  // Confusion at 10 cm: each detection against the nearest target object.
  for (const FrameOutcome& f : frames) {
    for (const ScoredDetection& d : f.detections) {
      std::string truth = "background";
      double best = 0.10;
      for (const TruthObject& t : f.truth) {
        if (t.furniture_class.empty() || all_objects(t) == Role::kAbsent) continue;
        const double distance = std::hypot(t.x - d.x, t.y - d.y);
        if (distance <= best) {
          best = distance;
          truth = t.furniture_class;
        }
      }
      ++result.confusion[d.furniture_class][truth];
    }
  }

  // Protocol A: maxima in a square window around the objects, threshold swept.
  std::vector<double> thresholds = options.paper_thresholds;
  if (thresholds.empty()) {
    for (int k = 0; k <= 20; ++k) thresholds.push_back(k * 0.05);
  }
  for (const std::string& c : options.classes) {
    std::vector<PrPoint> curve;
    double best_f1 = 0;
    int class_objects = 0;
    for (double t : thresholds) {
      int tp = 0, fp = 0, found = 0;
      class_objects = 0;
      for (const FrameOutcome& f : frames) {
        std::vector<bool> hit(f.truth.size(), false);
        for (const HoughMaximum& h : f.maxima) {
          if (h.furniture_class != c || h.relative < t) continue;
          bool inside = false;
          for (size_t k = 0; k < f.truth.size(); ++k) {
            const TruthObject& o = f.truth[k];
            if (o.furniture_class != c || all_objects(o) == Role::kAbsent) continue;
            if (std::abs(o.x - h.x) <= options.paper_window_m &&
                std::abs(o.y - h.y) <= options.paper_window_m) {
              inside = true;
              hit[k] = true;
            }
          }
          inside ? ++tp : ++fp;
        }
        for (size_t k = 0; k < f.truth.size(); ++k) {
          if (f.truth[k].furniture_class != c || all_objects(f.truth[k]) != Role::kTarget) continue;
          ++class_objects;
          found += hit[k];
        }
      }
      if (class_objects == 0) break;
      const double recall = static_cast<double>(found) / class_objects;
      const double precision = tp + fp > 0 ? static_cast<double>(tp) / (tp + fp) : 1.0;
      curve.push_back({recall, precision, t});
      if (precision + recall > 0)
        best_f1 = std::max(best_f1, 2 * precision * recall / (precision + recall));
    }
    if (class_objects == 0) continue;
    result.curves["A/" + c] = curve;
    m["paper/" + c + "/best_f1"] = best_f1;
  }

  // Latency.
  std::vector<double> totals;
  std::map<std::string, std::vector<double>> stages;
  for (const FrameOutcome& f : frames) {
    totals.push_back(f.total_ms);
    for (const auto& [stage, ms] : f.stage_ms) stages[stage].push_back(ms);
  }
  m["latency_p50_ms"] = Percentile(totals, 0.5);
  m["latency_p90_ms"] = Percentile(totals, 0.9);
  m["latency_p99_ms"] = Percentile(totals, 0.99);
  for (const auto& [stage, values] : stages)
    m["latency_" + stage + "_p50_ms"] = Percentile(values, 0.5);
  return result;
}

}  // namespace furn
