// The report of a parameter search (`workbench tune`, SPEC.md §11): a
// self-contained folder (index.html plus PNG charts) that ranks the trials
// by the objective, plots the objective against each parameter's values and
// over the trials, and shows the best trial next to the base options on the
// validation and the test split.
//
//   TuneReportInput input;  // filled by the tune command
//   WriteTuneReport(input, "tune/");
#pragma once

#include <map>
#include <string>
#include <vector>

namespace furn {

struct TuneReportTrial {
  int index = 0;  // 0: the base options
  int64_t run_id = 0;
  std::vector<std::string> values;  // per parameter, as text (JSON)
  std::map<std::string, double> metrics;
  bool within_latency = true;  // p50 latency within --max-ms
  bool retrained = false;      // its trainer options differ from the base
};

struct TuneReportInput {
  std::string title;  // e.g. "tune 3f2a91c0 on synth.db, split val"
  std::string objective = "mAP@10cm";
  double max_ms = 0;                    // 0: no latency constraint
  std::vector<std::string> parameters;  // dotted option paths
  std::vector<TuneReportTrial> trials;  // ranked, best first
  std::string best_options_file;        // relative to the report folder
  // Base and best on both splits (empty maps when the test split was skipped).
  std::string validation_split, test_split;
  std::map<std::string, double> base_validation, best_validation, base_test, best_test;
  int best_index = 0;
  std::vector<std::string> notes;  // lines shown under the title (provenance, commands)
};

// Writes index.html and the plots into `dir` (created). Throws InputError
// naming the file when one cannot be written.
void WriteTuneReport(const TuneReportInput& input, const std::string& dir);

}  // namespace furn
