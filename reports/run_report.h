// The report of one evaluation run (SPEC.md §10): a self-contained folder
// (index.html plus PNGs, no network) with provenance, headline and per-class
// tables, PR curves of protocols A and B, the confusion matrix, the latency
// histogram, the options used, and a gallery of the frames with the most
// errors (their detection debug PNGs, made by the caller). Plots are drawn
// in-process (reports/chart.h): no text of a run becomes a program.
//
//   RunReportInput input{run, metrics, frame_ms, gallery};
//   WriteRunReport(input, "report/");
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "db/dataset_db.h"
#include "reports/run_results.h"

namespace furn {

struct GalleryFrame {
  int64_t frame_id = 0;
  int false_positives = 0, false_negatives = 0;
  std::string dir;  // relative to the report folder, holding the debug PNGs
  std::vector<std::string> pngs;
};

struct RunReportInput {
  RunRecord run;
  // run.results_json as read (RunResults::Parse, naming its file); unset:
  // the report reads it, naming the run alone.
  std::optional<RunResults> results;
  std::map<std::string, double> metrics;
  std::vector<double> frame_ms;  // total detection time per frame
  std::vector<GalleryFrame> gallery;
  // A leave-models-out run's training budget against the default model's
  // (HTML, shown under its heading); empty: none to say.
  std::string budget_note;
};

// Writes index.html and the plots into `dir` (created). Throws InputError
// naming the file when one cannot be written.
void WriteRunReport(const RunReportInput& input, const std::string& dir);

// The report of a leave-models-out run (protocol E, kind "crossval"): the
// per-fold table (models held out, frames, objects, mAP and per-class AP) with
// mean and spread, a plot of AP per class and fold, the options and every
// metric. `fold_reports[k]` is the folder (relative to `dir`) of fold k's own
// run report, linked from its row; empty for none.
void WriteCrossvalReport(const RunReportInput& input,
                         const std::vector<std::string>& fold_reports,
                         const std::string& dir);

// The runs of one dataset, for the history page.
struct HistoryDataset {
  std::string name;  // shown in the table and the plots' key
  std::vector<RunRecord> runs;
  std::vector<std::map<std::string, double>> metrics;  // one per run
};

// Every metric across runs (and the commits they ran on) of one or more
// datasets (synthetic and real side by side): history.html with one table
// row per run and a plot per headline metric, one line per dataset, runs in
// the order they started, in `dir`.
void WriteHistoryReport(const std::vector<HistoryDataset>& datasets, const std::string& dir);

// Text safe inside HTML elements and attributes.
std::string HtmlEscape(const std::string& text);
// `value` with `digits` decimals; an en dash for NaN (a metric a run lacks).
std::string Number(double value, int digits = 3);

// An average precision with the number of objects it was measured on, for
// tables: "0.805 <small>(95)</small>" (NaN objects: the number alone).
std::string ApWithObjects(double ap, double objects);

// A paragraph and script that, once the page has loaded, say "images
// loaded: N of M", for a headless browser's --dump-dom to check.
std::string ImageCheckHtml();

}  // namespace furn
