#include "reports/run_results.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/util/error.h"

namespace furn {
namespace {

using JsonValue = nlohmann::json;

// The field's value of `object`, which must be of `type` ("what: field ...
// is not ..." otherwise).
const JsonValue& Field(const JsonValue& object,
                       const std::string& key,
                       JsonValue::value_t type,
                       const std::string& what) {
  const JsonValue& value = object.at(key);
  const bool number = type == JsonValue::value_t::number_float &&
                      (value.is_number() || value.is_null());  // NaN is stored as null
  Require(value.type() == type || number ||
              (type == JsonValue::value_t::number_integer && value.is_number_unsigned()),
          what + ": results field '" + key + "' is not of the type a run stores");
  return value;
}

double NumberOrNan(const JsonValue& value) {
  return value.is_number() ? value.get<double>() : std::numeric_limits<double>::quiet_NaN();
}

JsonValue CalibrationRows(const std::vector<CalibrationBin>& bins) {
  JsonValue rows = JsonValue::array();
  for (const CalibrationBin& bin : bins)
    rows.push_back({bin.low, bin.high, bin.detections, bin.true_positives, bin.score_sum});
  return rows;
}

std::vector<CalibrationBin> ReadCalibration(const JsonValue& rows, const std::string& what) {
  Require(rows.is_array(), what + ": results field 'calibration' is not a list");
  std::vector<CalibrationBin> bins;
  for (const JsonValue& row : rows) {
    Require(row.is_array() && row.size() == 5 &&
                std::all_of(row.begin(), row.end(), [](auto& v) { return v.is_number(); }),
            what + ": a calibration bin is not 5 numbers");
    bins.push_back({row[0].get<double>(),
                    row[1].get<double>(),
                    row[2].get<int>(),
                    row[3].get<int>(),
                    row[4].get<double>()});
  }
  return bins;
}

void ReadEvaluation(const JsonValue& json, const std::string& what, RunResults* results) {
  if (json.contains("curves")) {
    const JsonValue& curves = Field(json, "curves", JsonValue::value_t::object, what);
    for (const auto& [name, points] : curves.items()) {
      Require(points.is_array(), what + ": curve '" + name + "' is not a list");
      std::vector<PrPoint>& curve = results->curves[name];
      for (const JsonValue& p : points) {
        Require(p.is_array() && p.size() == 3 && p[0].is_number() && p[1].is_number() &&
                    p[2].is_number(),
                what + ": a point of curve '" + name + "' is not recall, precision, threshold");
        curve.push_back({p[0].get<double>(), p[1].get<double>(), p[2].get<double>()});
      }
    }
  }
  results->confusion_has_missed = json.contains("confusion_layout");
  results->confusion_by_object = json.contains("confusion_extra");
  if (results->confusion_by_object) {
    const JsonValue& extra = json["confusion_extra"];
    Require(extra.is_number_integer() && extra.get<int64_t>() >= 0 &&
                extra.get<int64_t>() <= std::numeric_limits<int>::max(),
            what + ": confusion_extra is not a count");
    results->confusion_extra = extra.get<int>();
  }
  if (json.contains("confusion")) {
    for (const auto& [detected, row] :
         Field(json, "confusion", JsonValue::value_t::object, what).items()) {
      Require(row.is_object(), what + ": confusion row '" + detected + "' is not an object");
      for (const auto& [truth, count] : row.items()) {
        Require(count.is_number_integer(), what + ": a confusion count is not a whole number");
        results->confusion[detected][truth] = count.get<int>();
      }
    }
  }
  if (json.contains("frame_errors")) {
    for (const auto& [frame, counts] :
         Field(json, "frame_errors", JsonValue::value_t::object, what).items()) {
      Require(counts.is_array() && counts.size() == 2 && counts[0].is_number_integer() &&
                  counts[1].is_number_integer(),
              what + ": frame " + frame + "'s errors are not two whole numbers");
      size_t used = 0;
      int64_t id = 0;
      try {
        id = std::stoll(frame, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      Require(used == frame.size() && !frame.empty(),
              what + ": frame errors name a frame '" + frame + "' that is not a frame id");
      results->frame_errors[id] = {counts[0].get<int>(), counts[1].get<int>()};
    }
  }
}

void ReadFolds(const JsonValue& folds, const std::string& what, RunResults* results) {
  Require(folds.is_array(), what + ": results field 'folds' is not a list");
  for (const JsonValue& fold : folds) {
    Require(fold.is_object(), what + ": a fold is not an object");
    FoldResult f;
    f.fold = fold.contains("fold")
                 ? Field(fold, "fold", JsonValue::value_t::number_integer, what).get<int>()
                 : 0;
    f.run = fold.contains("run")
                ? Field(fold, "run", JsonValue::value_t::number_integer, what).get<int64_t>()
                : 0;
    if (fold.contains("held_out")) {
      for (const auto& [name, count] :
           Field(fold, "held_out", JsonValue::value_t::object, what).items()) {
        Require(count.is_number_integer(), what + ": a fold's held-out count is not whole");
        f.held_out[name] = count.get<int>();
      }
    }
    if (fold.contains("metrics")) {
      for (const auto& [name, value] :
           Field(fold, "metrics", JsonValue::value_t::object, what).items()) {
        Require(value.is_number() || value.is_null(),
                what + ": fold metric " + name + " is not a number");
        f.metrics[name] = NumberOrNan(value);
      }
    }
    results->folds.push_back(std::move(f));
  }
}

}  // namespace

RunResults RunResults::OfEvaluation(const EvaluationResult& result) {
  RunResults results;
  results.kind = Kind::kEvaluation;
  for (const auto& [name, curve] : result.curves) results.curves[name] = curve;
  results.calibration = result.calibration;
  results.confusion = ConfusionByName(result);
  results.confusion_extra = result.confusion_extra;
  for (const auto& [frame, errors] : result.frame_errors) results.frame_errors[frame] = errors;
  return results;
}

std::string RunResults::Json() const {
  JsonValue json;
  json["calibration"] = CalibrationRows(calibration);
  json["calibration_layout"] = "low, high, detections, true positives, score sum";
  if (kind == Kind::kCrossval) {
    JsonValue per_fold = JsonValue::array();
    for (const FoldResult& fold : folds) {
      per_fold.push_back({{"fold", fold.fold},
                          {"run", fold.run},
                          {"held_out", fold.held_out},
                          {"metrics", fold.metrics}});
    }
    json["folds"] = per_fold;
    return json.dump(-1, ' ', false, JsonValue::error_handler_t::replace);
  }
  JsonValue curve_json = JsonValue::object();
  for (const auto& [name, curve] : curves) {
    JsonValue points = JsonValue::array();
    for (const PrPoint& p : curve) points.push_back({p.recall, p.precision, p.threshold});
    curve_json[name] = points;
  }
  JsonValue errors = JsonValue::object();
  for (const auto& [frame, counts] : frame_errors)
    errors[std::to_string(frame)] = {counts.first, counts.second};
  json["curves"] = curve_json;
  json["curve_layout"] = "recall, precision, threshold";
  json["confusion"] = confusion;
  json["confusion_layout"] =
      "{detected class or missed: {true class or background: count}}, detections at the "
      "operating point within 10 cm, each object once; background: detections near no object";
  json["confusion_extra"] = confusion_extra;
  json["frame_errors"] = errors;
  json["frame_errors_layout"] =
      "false positives, missed objects at 10 cm, detections at the operating point";
  return json.dump(-1, ' ', false, JsonValue::error_handler_t::replace);
}

RunResults RunResults::Parse(const std::string& text, const std::string& what) {
  const JsonValue json = JsonValue::parse(text, nullptr, /*allow_exceptions=*/false);
  Require(json.is_object(), what + ": its results are not a JSON object");
  RunResults results;
  results.kind = json.contains("folds") ? Kind::kCrossval : Kind::kEvaluation;
  results.calibration_stored = json.contains("calibration");
  if (results.calibration_stored) results.calibration = ReadCalibration(json["calibration"], what);
  if (results.kind == Kind::kCrossval) {
    ReadFolds(json["folds"], what, &results);
  } else {
    ReadEvaluation(json, what, &results);
  }
  return results;
}

}  // namespace furn
