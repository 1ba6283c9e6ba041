#include "workbench/pipelines/regression.h"

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/metric_id.h"

namespace furn {

std::vector<Regression> FindRegressions(const std::map<std::string, double>& run,
                                        const std::map<std::string, double>& baseline,
                                        double tolerance,
                                        const std::map<std::string, double>& overrides,
                                        double latency_tolerance) {
  std::vector<Regression> regressions;
  for (const auto& [metric, base] : baseline) {
    const auto it = run.find(metric);
    const MetricId id = MetricId::Parse(metric);  // a misspelt baseline metric is an error
    const bool latency = id.Unit() == std::string("ms");
    if (latency && latency_tolerance <= 0) continue;
    if (id.Unit() == std::string("count") || id.group() == MetricId::Group::kSpread)
      continue;  // sizes, spreads and diagnostic counts, not quality
    if (it == run.end()) {
      regressions.push_back({metric, std::nan(""), base, 0});  // a metric that vanished
      continue;
    }
    const auto override_it = overrides.find(metric);
    const double allowed = override_it != overrides.end() ? override_it->second
                           : latency                      ? latency_tolerance * std::abs(base)
                                                          : tolerance;
    const double worse = id.HigherIsBetter() ? base - it->second : it->second - base;
    if (worse > allowed) regressions.push_back({metric, it->second, base, allowed});
  }
  return regressions;
}

Baseline LoadBaseline(DatasetDb& dataset, const std::string& db_path, const std::string& spec) {
  Baseline baseline;
  if (spec.find_first_not_of("0123456789") == std::string::npos) {
    baseline.metrics = dataset.RunMetrics(std::stoll(spec));
    Require(!baseline.metrics.empty(), db_path + ": no baseline run with id " + spec);
    baseline.name = "run " + spec;
    return baseline;
  }
  try {
    const nlohmann::json json = nlohmann::json::parse(ReadFileBytes(spec));
    baseline.metrics = json.at("metrics").get<std::map<std::string, double>>();
    if (json.contains("tolerances"))
      baseline.tolerances = json["tolerances"].get<std::map<std::string, double>>();
  } catch (const nlohmann::json::exception& error) {
    throw InputError(spec +
                     ": not a baseline file ({\"metrics\": {name: value}}): " + error.what());
  }
  baseline.name = spec;
  return baseline;
}

void WriteBaselineFile(const std::string& path,
                       int64_t run_id,
                       const std::string& db_path,
                       const std::map<std::string, double>& metrics) {
  nlohmann::ordered_json json{{"run", run_id},
                              {"db", db_path},
                              {"metrics", metrics},
                              {"tolerances", nlohmann::json::object()}};
  WriteFileAtomically(path,
                      json.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

}  // namespace furn
