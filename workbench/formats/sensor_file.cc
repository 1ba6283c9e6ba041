#include "workbench/formats/sensor_file.h"

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "workbench/formats/json_text.h"

namespace furn {
namespace {

constexpr char kFormat[] = "furnidet-sensor";
constexpr int kVersion = 1;

// Every option of the sensor model by its file key, in the file's order.
template <typename Options, typename Visit>
void VisitSensorFields(Options& o, Visit&& visit) {
  visit("baseline_m", o.baseline_m);
  visit("projector_shadow", o.projector_shadow);
  visit("range_limits", o.range_limits);
  visit("min_range_m", o.min_range_m);
  visit("max_range_m", o.max_range_m);
  visit("incidence_dropout", o.incidence_dropout);
  visit("max_incidence_deg", o.max_incidence_deg);
  visit("edge_dropout", o.edge_dropout);
  visit("edge_jump_m", o.edge_jump_m);
  visit("edge_dropout_probability", o.edge_dropout_probability);
  visit("lateral_noise", o.lateral_noise);
  visit("axial_noise", o.axial_noise);
  visit("noise_scale", o.noise_scale);
  visit("correlated_share", o.correlated_share);
  visit("correlation_radius_px", o.correlation_radius_px);
  visit("quantization", o.quantization);
  visit("disparity_step_px", o.disparity_step_px);
}

template <typename T>
void ReadField(const nlohmann::ordered_json& value, const std::string& where, T* field) {
  if constexpr (std::is_same_v<T, bool>) {
    Require(value.is_boolean(), where + " must be true or false");
    *field = value.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    Require(value.is_number_integer(), where + " must be an integer");
    const int64_t n = value.get<int64_t>();
    Require(n >= -1000000 && n <= 1000000, where + " is out of range");
    *field = static_cast<T>(n);
  } else {
    Require(value.is_number(), where + " must be a number");
    *field = value.get<double>();
    Require(std::isfinite(*field), where + " must be finite");
  }
}

}  // namespace

std::string SensorFileJson(const KinectNoiseOptions& options,
                           const std::string& fitted_on,
                           double fit_error) {
  nlohmann::ordered_json noise = nlohmann::ordered_json::object();
  VisitSensorFields(options, [&](const char* key, const auto& value) { noise[key] = value; });
  nlohmann::ordered_json json{{"format", kFormat}, {"version", kVersion}};
  if (!fitted_on.empty()) json["fitted_on"] = fitted_on;
  if (std::isfinite(fit_error)) json["fit_error"] = fit_error;
  json["noise"] = noise;
  return json.dump(2) + "\n";
}

KinectNoiseOptions SensorOptionsFromJson(const std::string& text, const std::string& what) {
  const nlohmann::ordered_json json = ParseUserJson(text, what);
  Require(json.is_object(), what + ": a sensor file is a JSON object");
  Require(json.contains("format") && json["format"] == kFormat,
          what + ": not a sensor file (\"format\" must be \"" + kFormat + "\")");
  Require(json.contains("version") && json["version"].is_number_integer() &&
              json["version"].get<int64_t>() == kVersion,
          what + ": sensor file \"version\" must be " + std::to_string(kVersion) +
              " (a newer file needs a newer build)");
  for (const auto& [key, value] : json.items()) {
    Require(key == "format" || key == "version" || key == "fitted_on" || key == "fit_error" ||
                key == "noise",
            what + ": unknown key '" + key + "' (format, version, fitted_on, fit_error, noise)");
  }
  Require(json.contains("noise") && json["noise"].is_object(),
          what + ": \"noise\" must be an object of sensor options");
  KinectNoiseOptions options;
  std::set<std::string> known;
  VisitSensorFields(options, [&](const char* key, auto& field) {
    known.insert(key);
    if (json["noise"].contains(key)) ReadField(json["noise"][key], what + ": noise." + key, &field);
  });
  for (const auto& [key, value] : json["noise"].items())
    Require(known.count(key) > 0, what + ": unknown sensor option 'noise." + key + "'");
  try {
    options.Check();
  } catch (const InputError& e) {
    throw InputError(what + ": noise." + e.what());
  }
  return options;
}

KinectNoiseOptions ReadSensorFile(const std::string& path) {
  std::error_code error;
  const uintmax_t bytes = std::filesystem::file_size(path, error);
  Require(!error, path + ": cannot read the sensor file (" + error.message() + ")");
  Require(bytes <= kMaxSensorFileBytes,
          path + ": a sensor file is at most " + std::to_string(kMaxSensorFileBytes) +
              " bytes (this one has " + std::to_string(bytes) + ")");
  return SensorOptionsFromJson(ReadFileBytes(path), path);
}

}  // namespace furn
