// `workbench regress`: a run's metrics against a baseline (another run of
// the dataset, or a JSON file of metrics and tolerances).
//
//   const Baseline baseline = LoadBaseline(dataset, "synth.db", "run:12");
//   for (const Regression& r : FindRegressions(metrics, baseline.metrics, tolerances)) ...
#pragma once

#include <map>
#include <string>
#include <vector>

#include "db/dataset_db.h"

namespace furn {

struct Regression {
  std::string metric;
  double value = 0, baseline = 0, tolerance = 0;
};

// Metrics of `run` that are worse than `baseline` by more than the tolerance
// (absolute; per-metric overrides win). Latency metrics are compared only
// when `latency_tolerance` (relative, e.g. 0.5 = 50 % slower) is positive.
std::vector<Regression> FindRegressions(const std::map<std::string, double>& run,
                                        const std::map<std::string, double>& baseline,
                                        double tolerance,
                                        const std::map<std::string, double>& overrides,
                                        double latency_tolerance);

// What `regress` compares against: another run of the dataset (`spec` is
// its id) or a baseline file ({"metrics": {name: value}, "tolerances":
// {name: allowed worsening}}, as WriteBaselineFile writes it).
struct Baseline {
  std::string name;  // "run 7" or the file's path
  std::map<std::string, double> metrics, tolerances;
};
Baseline LoadBaseline(DatasetDb& dataset, const std::string& db_path, const std::string& spec);
void WriteBaselineFile(const std::string& path,
                       int64_t run_id,
                       const std::string& db_path,
                       const std::map<std::string, double>& metrics);

}  // namespace furn
