#include "reports/run_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/chart.h"
#include "reports/confusion.h"
#include "reports/evaluation.h"
#include "reports/run_results.h"

namespace furn {
namespace {

// The classes a report shows: the paper's four, then any other class the
// run has data for (a sofa where the dataset has sofas).
std::vector<FurnitureClass> ReportedClasses(const std::function<bool(FurnitureClass)>& has_data) {
  std::vector<FurnitureClass> classes(kPaperClasses.begin(), kPaperClasses.end());
  for (FurnitureClass c : kAllClasses) {
    if (std::find(classes.begin(), classes.end(), c) == classes.end() && has_data(c))
      classes.push_back(c);
  }
  return classes;
}

// Whether any metric of `metrics` is about class `c`.
bool HasClassMetrics(const std::map<std::string, double>& metrics, FurnitureClass c) {
  const std::string name = ClassName(c);
  for (const auto& [metric, value] : metrics) {
    if (metric.find("/" + name + "@") != std::string::npos ||
        metric.find("/" + name + "/") != std::string::npos)
      return true;
  }
  return false;
}

// A PR plot of the named curves (recall, precision) from the run's results.
void PlotCurves(const std::map<std::string, std::vector<PrPoint>>& curves,
                const std::string& prefix,
                const std::string& suffix,
                const std::string& title,
                const std::map<std::string, double>& metrics,
                const std::string& png_path) {
  Chart chart;
  chart.title = title;
  chart.x = MakeAxis("recall", 0, 1);
  chart.y = MakeAxis("precision", 0, 1.02);
  chart.empty_note = "no objects of these classes";
  const std::vector<FurnitureClass> classes = ReportedClasses(
      [&](FurnitureClass c) { return curves.count(prefix + ClassName(c) + suffix) > 0; });
  for (FurnitureClass furniture_class : classes) {
    const std::string c = ClassName(furniture_class);
    const std::string name = prefix + c + suffix;
    const auto curve = curves.find(name);
    if (curve == curves.end() || curve->second.empty()) continue;
    ChartSeries series =
        MakeSeries(c + " (" + Number(ClassObjectCount(metrics, furniture_class), 0) + " objects)",
                   ChartStyle::kLinesPoints,
                   ChartPalette(chart.series.size()));
    for (const PrPoint& p : curve->second) {
      series.x.push_back(p.recall);
      series.y.push_back(p.precision);
    }
    chart.series.push_back(series);
  }
  WriteChartPng(chart, png_path);
}

// The page's head, style and provenance table.
std::string PageHead(const std::string& title, const RunRecord& run);

}  // namespace

std::string HtmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Number(double value, int digits) {
  if (std::isnan(value)) return "–";
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", digits, value);
  return text;
}

std::string ApWithObjects(double ap, double objects) {
  if (std::isnan(objects)) return Number(ap);
  return Number(ap) + " <small>(" + Number(objects, 0) + ")</small>";
}

std::string ImageCheckHtml() {
  return "<p id=\"image-check\">images not checked</p>\n<script>\n"
         "window.addEventListener('load', function () {\n"
         "  var images = document.images, loaded = 0;\n"
         "  for (var i = 0; i < images.length; ++i) if (images[i].naturalWidth > 0) ++loaded;\n"
         "  document.getElementById('image-check').textContent =\n"
         "      'images loaded: ' + loaded + ' of ' + images.length;\n"
         "});\n</script>\n";
}

namespace {

struct HistoryRow {
  const HistoryDataset* dataset;
  const RunRecord* run;
  const std::map<std::string, double>* metrics;
};

// What made a run's detections, as its stored options say: "learned" or
// "codebook" (the hypothesis source; runs stored before it was recorded:
// their voting option when it names one), another program's name, or "".
std::string RunDetector(const RunRecord& run) {
  const nlohmann::json options = nlohmann::json::parse(run.options_json, nullptr, false);
  if (!options.is_object()) return "";
  if (options.contains("detections") && options["detections"].is_object()) {
    const nlohmann::json& name = options["detections"].value("detector", nlohmann::json());
    return name.is_string() ? name.get<std::string>().substr(0, 40) : "";
  }
  if (options.contains("hypotheses") && options["hypotheses"].is_string())
    return options["hypotheses"].get<std::string>();
  if (options.contains("detector") && options["detector"].is_object()) {
    const nlohmann::json& voting = options["detector"].value("voting", nlohmann::json());
    if (voting == "learned" || voting == "codebook") return voting.get<std::string>();
  }
  return "";
}

// The line a run belongs on: its dataset, the frames it measured, what
// detected (learned, codebook, another program) and, for anything but a
// plain evaluation, its kind. Runs on the validation split (tuning) and on
// the test split, or of the two hypothesis sources, are never one line.
std::string HistorySeries(const HistoryRow& row) {
  std::string series = row.dataset->name + ", " + EnumName(row.run->split);
  const std::string detector = RunDetector(*row.run);
  if (!detector.empty()) series += ", " + detector;
  if (row.run->kind != "evaluate") series += " (" + row.run->kind + ")";
  return series;
}

// Every line's name in the order its first run started.
std::vector<std::string> HistorySeriesNames(const std::vector<HistoryRow>& rows) {
  std::vector<std::string> names;
  for (const HistoryRow& row : rows) {
    const std::string name = HistorySeries(row);
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  }
  return names;
}

// One metric over the runs, a line per series.
Chart HistoryChart(const std::vector<HistoryRow>& rows, const std::string& metric) {
  Chart chart;
  chart.width = 560;
  chart.height = 340;
  chart.title = metric + " by run";
  chart.x.label =
      "run, in the order they started: its commit (+ uncommitted changes) below, "
      "its label above the point";
  // A tick per run (at most 12: every n-th), named by its commit.
  const size_t step = std::max<size_t>(1, (rows.size() + 11) / 12);
  for (size_t k = 0; k < rows.size(); k += step) {
    chart.x.ticks.emplace_back(
        static_cast<double>(k + 1),
        rows[k].run->git_commit.substr(0, 7) + (rows[k].run->git_dirty ? "+" : ""));
  }
  const bool labelled = rows.size() <= 24;  // more labels than that overlap
  chart.legend = LegendPlace::kBelow;
  chart.empty_note = "no run has this metric";
  const std::vector<std::string> names = HistorySeriesNames(rows);
  for (size_t s = 0; s < names.size(); ++s) {
    ChartSeries series = MakeSeries(names[s], ChartStyle::kLinesPoints, ChartPalette(s));
    for (size_t k = 0; k < rows.size(); ++k) {
      if (HistorySeries(rows[k]) != names[s]) continue;
      const auto it = rows[k].metrics->find(metric);
      if (it == rows[k].metrics->end() || !std::isfinite(it->second)) continue;
      series.x.push_back(static_cast<double>(k + 1));
      series.y.push_back(it->second);
      if (labelled) series.labels.push_back(rows[k].run->label.substr(0, 16));
    }
    if (!series.x.empty()) chart.series.push_back(series);
  }
  return chart;
}

// The table of every metric of every run, a row per run.
std::string HistoryTableHtml(const std::vector<HistoryRow>& rows) {
  std::vector<std::string> names;  // every metric any run has, sorted
  for (const HistoryRow& row : rows) {
    for (const auto& [name, value] : *row.metrics) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  std::ostringstream html;
  html << "<table><tr><th>#</th><th>dataset</th><th>split</th><th>run</th><th>started</th>"
       << "<th>commit</th><th>kind</th><th>detector</th><th>label</th>";
  for (const std::string& name : names) html << "<th>" << HtmlEscape(name) << "</th>";
  html << "</tr>\n";
  for (size_t k = 0; k < rows.size(); ++k) {
    const HistoryRow& row = rows[k];
    const RunRecord& run = *row.run;
    html << "<tr><td>" << k + 1 << "</td><td>" << HtmlEscape(row.dataset->name) << "</td><td>"
         << EnumName(run.split) << "</td><td>" << run.id << "</td><td>" << HtmlEscape(run.started)
         << "</td><td>" << HtmlEscape(run.git_commit.substr(0, 10)) << (run.git_dirty ? "+" : "")
         << "</td><td>" << HtmlEscape(run.kind) << "</td><td>" << HtmlEscape(RunDetector(run))
         << "</td><td>" << HtmlEscape(run.label) << "</td>";
    for (const std::string& name : names) {  // stored names, of any version
      const auto it = row.metrics->find(name);
      html << "<td>" << Number(it == row.metrics->end() ? std::nan("") : it->second, 3) << "</td>";
    }
    html << "</tr>\n";
  }
  return html.str();
}

}  // namespace

void WriteHistoryReport(const std::vector<HistoryDataset>& datasets, const std::string& dir) {
  std::vector<HistoryRow> rows;
  for (const HistoryDataset& d : datasets) {
    Require(d.runs.size() == d.metrics.size(), d.name + ": a metrics map per run is needed");
    for (size_t r = 0; r < d.runs.size(); ++r) rows.push_back({&d, &d.runs[r], &d.metrics[r]});
  }
  Require(!rows.empty(), "history needs at least one run");
  // Runs in the order they started (ISO 8601 sorts as text); ties by dataset and id.
  std::stable_sort(rows.begin(), rows.end(), [](const HistoryRow& a, const HistoryRow& b) {
    return a.run->started < b.run->started;
  });
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  Require(!error, dir + ": cannot create the history directory (" + error.message() + ")");
  auto path = [&](const std::string& name) { return (std::filesystem::path(dir) / name).string(); };
  const std::vector<std::string> plotted = {MetricId::MeanAp(0.10).Name(),
                                            MetricId::MeanAp(0.05).Name(),
                                            MetricId::MeanAp(0.20).Name(),
                                            MetricId::Plain(PlainMetric::kFalseAboveTrue).Name(),
                                            MetricId::Plain(PlainMetric::kXyErrorMean).Name(),
                                            MetricId::Plain(PlainMetric::kLatencyP50).Name()};
  for (size_t p = 0; p < plotted.size(); ++p) {
    WriteChartPng(HistoryChart(rows, plotted[p]), path("history_" + std::to_string(p) + ".png"));
  }
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>furnidet "
       << "history</title>\n<style>body{font-family:sans-serif;margin:24px}table{border-collapse:"
       << "collapse;font-size:12px}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
       << "th{background:#f0f0f0;position:sticky;top:0}td:nth-child(-n+9),th:nth-child(-n+9)"
       << "{text-align:left}img{border:1px solid #ddd;margin:4px}</style></head><body>\n"
       << "<h1>Metric history (" << rows.size() << " runs";
  if (datasets.size() > 1) {
    html << " of " << datasets.size() << " datasets:";
    for (const HistoryDataset& d : datasets) html << " " << HtmlEscape(d.name);
  }
  html << ")</h1>\n<p>One line per dataset, split and detector (learned vote map, codebook, "
          "another program; and run kind): a run on other frames or of another detector is "
          "another line, never a step in this one. The x axis is the runs in the order they "
          "started (# in the table), named by commit; the label is above each point. Lines:";
  for (const std::string& series : HistorySeriesNames(rows)) {
    html << " <span class=\"series\">" << HtmlEscape(series) << "</span> ("
         << std::count_if(rows.begin(),
                          rows.end(),
                          [&](const HistoryRow& row) { return HistorySeries(row) == series; })
         << " runs);";
  }
  html << "</p>\n<div>";
  for (size_t p = 0; p < plotted.size(); ++p)
    html << "<img src=\"history_" << p << ".png\" alt=\"" << HtmlEscape(plotted[p]) << "\">";
  html << "</div>\n" << HistoryTableHtml(rows);
  html << "</table>\n<p>+ after a commit: run on a working tree with uncommitted changes.</p>\n"
       << "</body></html>\n";
  WriteFileAtomically(path("history.html"), html.str());
}

namespace {

// What the protocol letters in headings, help and docs stand for
// (docs/evaluation.md, "Protocols A to E").
std::string ProtocolGlossaryHtml() {
  return "<h2 id=\"protocols\">Protocols</h2>\n<dl class=\"glossary\">"
         "<dt>A</dt><dd>the paper's detection protocol: a Hough maximum (or learned heat "
         "peak) within a 5 cm square window of an object's reference point is a hit; the "
         "relative threshold is swept (<code>paper/&lt;class&gt;/best_f1</code>)</dd>"
         "<dt>B</dt><dd>detection AP: detections by score matched greedily to objects of their "
         "class by centre distance, 5, 10 and 20 cm (<code>AP/&lt;class&gt;@10cm</code>); the "
         "box metrics match by 3-D or bird's-eye IoU instead (<code>AP3D</code>, "
         "<code>APBEV</code>)</dd>"
         "<dt>C</dt><dd>the paper's classification protocol: its 8 CAD models split by part "
         "subset, CAD model and category accuracy</dd>"
         "<dt>D</dt><dd>the vocabulary comparison: k-means against RIM over several seeds "
         "(<code>evaluate --compare-vocab</code>)</dd>"
         "<dt>E</dt><dd>leave-models-out: the CAD models split into folds, each fold's held out "
         "of training and the only furniture of the rooms that evaluate it: furniture never "
         "trained on (<code>crossval</code>)</dd></dl>\n";
}

std::string PageHead(const std::string& title, const RunRecord& run) {
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
       << "<title>furnidet run " << run.id << "</title>\n<style>\n"
       << "body{font-family:sans-serif;margin:24px;max-width:1400px;color:#222}"
       << "table{border-collapse:collapse;margin:8px 0 20px}td,th{border:1px solid #ccc;"
       << "padding:4px 10px;text-align:right}th{background:#f0f0f0}td:first-child,th:first-child"
       << "{text-align:left}img{max-width:100%;border:1px solid #ddd}.row{display:flex;gap:16px;"
       << "flex-wrap:wrap}.row>div{flex:1 1 420px}pre{background:#f7f7f7;padding:10px;"
       << "overflow-x:auto;font-size:12px}.gallery img{width:300px}\n</style></head><body>\n";
  html << "<h1>" << HtmlEscape(title) << " " << run.id << "</h1>\n<table>"
       << "<tr><th>started</th><td>" << HtmlEscape(run.started) << "</td></tr>"
       << "<tr><th>commit</th><td>" << HtmlEscape(run.git_commit)
       << (run.git_dirty ? " (dirty)" : "") << "</td></tr>"
       << "<tr><th>split</th><td>" << HtmlEscape(EnumName(run.split)) << "</td></tr>"
       << "<tr><th>" << (run.kind == "external" ? "detections" : "model") << "</th><td>"
       << HtmlEscape(run.model_path)
       << (run.model_hash.empty() ? "" : " · " + HtmlEscape(run.model_hash))
       << "</td></tr>"
       // A leave-models-out run spans its folds' runs, each with its own model
       // and subset of the dataset: no one hash to show.
       << "<tr><th>dataset hash</th><td>"
       << (run.dataset_hash.empty() ? "– (one per fold run)" : HtmlEscape(run.dataset_hash))
       << "</td></tr>"
       << "<tr><th>label</th><td>" << HtmlEscape(run.label) << "</td></tr></table>\n";
  return html.str();
}

// The options and every metric, then the image self-check; ends the page.
std::string PageTail(const RunRecord& run, const std::map<std::string, double>& metrics) {
  std::ostringstream html;
  html << ProtocolGlossaryHtml() << "<h2>Options</h2>\n<pre>"
       << HtmlEscape(nlohmann::json::parse(run.options_json).dump(2))
       << "</pre>\n<h2>All metrics</h2>\n<table><tr><th>metric</th><th>value</th></tr>";
  for (const auto& [name, value] : metrics)
    html << "<tr><td>" << HtmlEscape(name) << "</td><td>" << Number(value, 4) << "</td></tr>";
  // A self-check a headless browser can read back (--dump-dom): how many
  // images loaded with a size.
  html << "</table>\n" << ImageCheckHtml() << "</body></html>\n";
  return html.str();
}

// Where the objects were lost (evaluation.h's funnel), a row per class, and
// the false positives by kind; `metric` gives a count (NaN: none).
std::string FunnelHtml(const std::vector<FurnitureClass>& classes,
                       const std::function<double(const MetricId&)>& metric) {
  std::ostringstream html;
  html << "<h2>Where objects are lost (10 cm)</h2>\n<p>Each object to find is counted once: "
          "found, or the furthest stage a maximum of its class (Hough or learned heat; another "
          "program's: its detections) within 15 cm of it reached. Stages in pipeline order; "
          "each class's largest loss in bold: start tuning there.</p>\n<table><tr><th>stage "
          "reached</th>";
  std::vector<std::optional<FurnitureClass>> columns(classes.begin(), classes.end());
  columns.push_back(std::nullopt);  // all
  for (const std::optional<FurnitureClass>& c : columns)
    html << "<th>" << (c ? ClassName(*c) : "all") << "</th>";
  html << "</tr>";
  // Per column, the largest count of a stage other than detected.
  std::vector<double> largest(columns.size(), 0);
  for (size_t k = 0; k < columns.size(); ++k) {
    for (FunnelStage stage : EnumValues<FunnelStage>()) {
      const double n = metric(MetricId::Funnel(columns[k], stage));
      if (stage != FunnelStage::kDetected && !std::isnan(n)) largest[k] = std::max(largest[k], n);
    }
  }
  for (FunnelStage stage : EnumValues<FunnelStage>()) {
    html << "<tr><td>" << FunnelStageWords(stage) << "</td>";
    for (size_t k = 0; k < columns.size(); ++k) {
      const double n = metric(MetricId::Funnel(columns[k], stage));
      const std::string text = std::isnan(n) ? std::string("0") : Number(n, 0);
      const bool worst = stage != FunnelStage::kDetected && n > 0 && n == largest[k];
      html << "<td>" << (worst ? "<b>" + text + "</b>" : text) << "</td>";
    }
    html << "</tr>";
  }
  html << "</table>\n<table><tr><th>false positives (10 cm)</th>";
  for (FalsePositiveKind kind : EnumValues<FalsePositiveKind>())
    html << "<th>" << EnumName(kind) << "</th>";
  html << "</tr><tr><td>all classes</td>";
  for (FalsePositiveKind kind : EnumValues<FalsePositiveKind>()) {
    const double n = metric(MetricId::FalsePositives(kind));
    html << "<td>" << (std::isnan(n) ? std::string("0") : Number(n, 0)) << "</td>";
  }
  html << "</tr></table>\n";
  return html.str();
}

// The reliability plot of a run's score (results' "calibration" bins: low,
// high, detections, true positives, score sum) and its table, as HTML; a
// note instead when the run has no bins or no detections.
std::string ReliabilityHtml(const std::vector<CalibrationBin>& bins,
                            double calibration_error,
                            const std::string& png_path,
                            const std::string& png_name) {
  std::ostringstream html;
  html << "<h2>Score calibration (reliability, 10 cm)</h2>\n";
  int total = 0;
  for (const CalibrationBin& bin : bins) total += bin.detections;
  if (total == 0) {
    html << "<p>No detections, so no calibration to show.</p>\n";
    return html.str();
  }
  Chart chart;
  chart.width = 520;
  chart.height = 420;
  chart.title =
      "true-positive share against mean score per bin (" + std::to_string(total) + " detections)";
  chart.x = MakeAxis("mean score in bin", 0, 1);
  chart.y = MakeAxis("true positives", 0, 1);
  chart.legend = LegendPlace::kTopLeft;
  ChartSeries diagonal = MakeSeries("perfectly calibrated",
                                    ChartStyle::kDashedLines,
                                    ChartColour{0x88, 0x88, 0x88},
                                    {0, 1},
                                    {0, 1});
  ChartSeries points = MakeSeries("bins", ChartStyle::kLinesPoints, ChartColour{0xcc, 0x33, 0x11});
  for (const CalibrationBin& bin : bins) {
    const int n = bin.detections;
    if (n == 0) continue;
    points.x.push_back(bin.score_sum / n);
    points.y.push_back(static_cast<double>(bin.true_positives) / n);
    points.labels.push_back(std::to_string(n));
  }
  chart.series = {diagonal, points};
  WriteChartPng(chart, png_path);
  html << "<p>Expected calibration error " << Number(calibration_error)
       << " (detection-weighted |true-positive share &minus; mean score|). A learned scorer's "
          "probabilities should lie on the diagonal; the fixed-gate ranking score is not a "
          "probability.</p>\n<div class=\"row\"><div><img src=\""
       << png_name << "\" alt=\"reliability plot\"></div><div><table><tr><th>score</th>"
       << "<th>detections</th><th>true positives</th><th>mean score</th></tr>";
  for (const CalibrationBin& bin : bins) {
    const int n = bin.detections;
    html << "<tr><td>" << Number(bin.low, 1) << "&ndash;" << Number(bin.high, 1) << "</td><td>" << n
         << "</td><td>" << bin.true_positives << "</td><td>"
         << (n ? Number(bin.score_sum / n) : "&ndash;") << "</td></tr>";
  }
  html << "</table></div></div>\n";
  return html.str();
}

// The run's results as the caller read them, or read here.
RunResults ResultsOf(const RunReportInput& input) {
  if (input.results) return *input.results;
  return RunResults::Parse(input.run.results_json, "run " + std::to_string(input.run.id));
}

// A fold's metric, NaN where it has none.
double FoldMetric(const FoldResult& fold, const MetricId& id) {
  const auto value = fold.metrics.find(id.Name());
  return value == fold.metrics.end() ? std::nan("") : value->second;
}

}  // namespace

namespace {

const double kDistances[] = {0.05, 0.10, 0.20};

// AP@10cm per class and fold, grouped bars.
void PlotFoldAp(const std::vector<FoldResult>& folds,
                const std::vector<FurnitureClass>& classes,
                const std::string& png_path) {
  Chart chart;
  chart.width = 760;
  chart.height = 380;
  chart.title =
      "leave-models-out: AP@10cm per class, one bar per fold (0 = none found, gap = no "
      "such object)";
  chart.y = MakeAxis("AP@10cm", 0, 1.05);
  chart.legend = LegendPlace::kRight;
  chart.empty_note = "no folds";
  for (size_t c = 0; c < classes.size(); ++c)
    chart.x.ticks.emplace_back(static_cast<double>(c), ClassName(classes[c]));
  const double width = 0.8 / static_cast<double>(std::max<size_t>(1, folds.size()));
  for (size_t k = 0; k < folds.size(); ++k) {
    ChartSeries bars = MakeSeries("fold " + std::to_string(k), ChartStyle::kBars, ChartPalette(k));
    bars.bar_width = width;
    for (size_t c = 0; c < classes.size(); ++c) {
      bars.x.push_back(static_cast<double>(c) - 0.4 + width * (static_cast<double>(k) + 0.5));
      bars.y.push_back(FoldMetric(folds[k], MetricId::ClassAp(classes[c], 0.10)));
    }
    chart.series.push_back(bars);
  }
  if (chart.series.empty()) chart.x.ticks.clear();
  WriteChartPng(chart, png_path);
}

// One row of the folds table: what it held out, its size, mAP and APs.
std::string FoldRowHtml(const FoldResult& fold,
                        const std::vector<FurnitureClass>& classes,
                        const std::string& fold_report) {
  std::ostringstream html;
  html << "<tr><td>" << fold.fold << "</td><td>";
  for (size_t c = 0; c < classes.size(); ++c) {
    const auto held_out = fold.held_out.find(ClassName(classes[c]));
    html << (c ? "/" : "") << (held_out == fold.held_out.end() ? 0 : held_out->second);
  }
  html << "</td><td>" << Number(FoldMetric(fold, MetricId::Plain(PlainMetric::kFrames)), 0)
       << "</td><td>" << Number(FoldMetric(fold, MetricId::Plain(PlainMetric::kObjects)), 0)
       << "</td>";
  for (double d : kDistances)
    html << "<td>" << Number(FoldMetric(fold, MetricId::MeanAp(d))) << "</td>";
  std::map<std::string, double> fold_metrics;  // those it has (NaN: none)
  for (const auto& [name, value] : fold.metrics)
    if (!std::isnan(value)) fold_metrics[name] = value;
  for (FurnitureClass c : classes) {
    html << "<td>"
         << ApWithObjects(FoldMetric(fold, MetricId::ClassAp(c, 0.10)),
                          ClassObjectCount(fold_metrics, c))
         << "</td>";
  }
  html << "<td>";
  if (!fold_report.empty()) {
    html << "<a href=\"" << HtmlEscape(fold_report) << "/index.html\">run " << fold.run << "</a>";
  } else {
    html << "run " << fold.run;
  }
  html << "</td></tr>";
  return html.str();
}

// The folds table: a row per fold, the mean +- spread, and the fixed gates.
std::string FoldsTableHtml(const std::vector<FoldResult>& folds,
                           const std::vector<FurnitureClass>& classes,
                           const std::vector<std::string>& fold_reports,
                           const std::map<std::string, double>& m) {
  std::ostringstream html;
  html << "<table><tr><th>fold</th><th>held out</th><th>frames</th>"
          "<th>objects</th><th>mAP @5cm</th><th>mAP @10cm</th><th>mAP @20cm</th>";
  for (FurnitureClass c : classes) html << "<th>" << ClassName(c) << " AP @10cm (objects)</th>";
  html << "<th>report</th></tr>";
  for (size_t k = 0; k < folds.size(); ++k)
    html << FoldRowHtml(folds[k], classes, k < fold_reports.size() ? fold_reports[k] : "");
  auto mean_spread = [&](const MetricId& id) {
    return "<td><b>" + Number(MetricOrNan(m, id)) + "</b> &plusmn; " +
           Number(MetricOrNan(m, id.InGroup(MetricId::Group::kSpread))) + "</td>";
  };
  html << "<tr><td><b>mean</b></td><td></td><td>"
       << Number(MetricOrNan(m, MetricId::Plain(PlainMetric::kFrames)), 0) << "</td><td>"
       << Number(MetricOrNan(m, MetricId::Plain(PlainMetric::kObjects)), 0) << "</td>";
  for (double d : kDistances) html << mean_spread(MetricId::MeanAp(d));
  for (FurnitureClass c : classes) html << mean_spread(MetricId::ClassAp(c, 0.10));
  html << "<td></td></tr>";
  const auto gates = [](const MetricId& id) { return id.InGroup(MetricId::Group::kGates); };
  if (m.count(gates(MetricId::MeanAp(0.10)).Name())) {  // the same folds without the learned scorer
    html << "<tr><td><b>fixed gates</b></td><td></td><td></td><td></td>";
    for (double d : kDistances)
      html << "<td>" << Number(MetricOrNan(m, gates(MetricId::MeanAp(d)))) << "</td>";
    for (FurnitureClass c : classes)
      html << "<td>" << Number(MetricOrNan(m, gates(MetricId::ClassAp(c, 0.10)))) << "</td>";
    html << "<td></td></tr>";
  }
  html << "</table>\n";
  return html.str();
}

// Pose and speed, mean and spread over the folds.
std::string PoseAndSpeedHtml(const std::map<std::string, double>& m) {
  std::ostringstream html;
  html << "<h2>Pose and speed (mean over folds)</h2>\n<table><tr><th>metric</th><th>mean</th>"
       << "<th>spread</th></tr>";
  for (PlainMetric plain : {PlainMetric::kXyErrorMean,
                            PlainMetric::kYawErrorMean,
                            PlainMetric::kLatencyP50,
                            PlainMetric::kLatencyP90}) {
    const MetricId id = MetricId::Plain(plain);
    html << "<tr><td>" << id.Name() << "</td><td>" << Number(MetricOrNan(m, id)) << "</td><td>"
         << Number(MetricOrNan(m, id.InGroup(MetricId::Group::kSpread))) << "</td></tr>";
  }
  html << "</table>\n";
  return html.str();
}

}  // namespace

void WriteCrossvalReport(const RunReportInput& input,
                         const std::vector<std::string>& fold_reports,
                         const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  Require(!error, dir + ": cannot create the report directory (" + error.message() + ")");
  const RunResults results = ResultsOf(input);
  const std::vector<FoldResult>& folds = results.folds;
  const std::map<std::string, double>& m = input.metrics;
  const std::vector<FurnitureClass> classes =
      ReportedClasses([&](FurnitureClass c) { return HasClassMetrics(m, c); });
  PlotFoldAp(folds, classes, (std::filesystem::path(dir) / "folds_ap.png").string());

  std::ostringstream html;
  html << PageHead("Leave-models-out run", input.run);
  html << "<h2>Protocol E: furniture never trained on</h2>\n<p>The class-mapped CAD models are "
          "split into "
       << folds.size()
       << " folds, stratified by class. Fold <i>k</i> is held "
          "out of training and its models are the only targets of the rooms that evaluate it "
          "(clutter as usual); every figure below is the mean over the folds &plusmn; the spread "
          "(standard deviation) between them. Held out: models per class (";
  for (size_t c = 0; c < classes.size(); ++c) html << (c ? " / " : "") << ClassName(classes[c]);
  html << ").</p>\n" << input.budget_note << FoldsTableHtml(folds, classes, fold_reports, m);
  if (m.count(MetricId::MeanAp(0.10).InGroup(MetricId::Group::kGates).Name())) {
    html << "<p>Rows per fold and <b>mean</b>: detection scored by the learned hypothesis scorer "
            "of each fold, trained on the hypotheses of the other folds' rooms only (nested, so "
            "no fold's furniture is seen by its own scorer). <b>fixed gates</b>: the same fold "
            "models with the fixed verification thresholds instead.</p>\n";
  }
  html << "<img src=\"folds_ap.png\" alt=\"AP per class and fold\">\n" << PoseAndSpeedHtml(m);
  if (results.calibration_stored) {  // pooled over the folds
    html << ReliabilityHtml(results.calibration,
                            MetricOrNan(m, MetricId::Plain(PlainMetric::kCalibrationError)),
                            (std::filesystem::path(dir) / "reliability.png").string(),
                            "reliability.png");
  }
  html << FunnelHtml(classes, [&](const MetricId& id) {  // counts: summed over the folds
    double sum = 0;
    bool any = false;
    for (const FoldResult& fold : folds) {
      const double n = FoldMetric(fold, id);
      if (std::isnan(n)) continue;
      sum += n;
      any = true;
    }
    return any ? sum : std::nan("");
  });
  html << PageTail(input.run, m);
  WriteFileAtomically((std::filesystem::path(dir) / "index.html").string(), html.str());
}

namespace {

// Latency histogram (10 ms bins).
void PlotLatency(const std::vector<double>& frame_ms, const std::string& png_path) {
  Chart chart;
  chart.width = 640;
  chart.height = 360;
  chart.title = "detection time per frame (" + std::to_string(frame_ms.size()) + " frames)";
  chart.x.label = "ms";
  chart.y.label = "frames";
  chart.y.min = 0;
  std::map<int64_t, int> bins;  // 10 ms bins by their lower edge / 10
  for (double ms : frame_ms) {
    if (std::isfinite(ms) && ms >= 0 && ms < 1e9) ++bins[static_cast<int64_t>(ms / 10)];
  }
  ChartSeries bars = MakeSeries("", ChartStyle::kBars, ChartPalette(0));
  bars.bar_width = 9;
  for (const auto& [bin, count] : bins) {
    bars.x.push_back(10.0 * static_cast<double>(bin) + 5);
    bars.y.push_back(count);
  }
  chart.series.push_back(bars);
  WriteChartPng(chart, png_path);
}

// Confusion at the operating point, 10 cm: rows the true class (background:
// nothing there), columns the detected class and "missed" (no detection
// within 10 cm). Runs stored before misses were counted keep the old square.
void PlotConfusion(const RunResults& results,
                   const std::vector<FurnitureClass>& classes,
                   const std::string& png_path) {
  std::vector<std::string> rows, columns;
  for (FurnitureClass c : classes) rows.push_back(ClassName(c));
  columns = rows;
  rows.push_back("background");
  const bool with_missed = results.confusion_has_missed;
  columns.push_back(with_missed ? "missed" : "background");
  std::vector<std::vector<int64_t>> counts(rows.size(), std::vector<int64_t>(columns.size(), 0));
  for (size_t column = 0; column < columns.size(); ++column) {
    const auto detected = results.confusion.find(columns[column]);
    if (detected == results.confusion.end()) continue;
    for (size_t row = 0; row < rows.size(); ++row) {
      const auto count = detected->second.find(rows[row]);
      if (count != detected->second.end()) counts[row][column] = count->second;
    }
  }
  const std::string title = !with_missed ? "every detection, 10 cm"
                            : results.confusion_by_object
                                ? "at the operating point, 10 cm: each object once"
                                : "at the operating point, 10 cm (kept detections)";
  WriteConfusionPng(rows, columns, counts, title, png_path);
}

// The headline metrics and the per-class table.
std::string SummaryHtml(const std::map<std::string, double>& m,
                        const std::vector<FurnitureClass>& classes,
                        const RunRecord& run) {
  std::ostringstream html;
  html << "<h2>Summary</h2>\n<table><tr><th>metric</th><th>value</th></tr>";
  const std::vector<MetricId> summary = {MetricId::Plain(PlainMetric::kFrames),
                                         MetricId::Plain(PlainMetric::kObjects),
                                         MetricId::MeanAp(0.05),
                                         MetricId::MeanAp(0.10),
                                         MetricId::MeanAp(0.20),
                                         MetricId::IouAp(std::nullopt, 0.25, false),
                                         MetricId::IouAp(std::nullopt, 0.5, false),
                                         MetricId::Plain(PlainMetric::kMeanApSeen),
                                         MetricId::Plain(PlainMetric::kMeanApUnseen),
                                         MetricId::Plain(PlainMetric::kXyErrorMean),
                                         MetricId::Plain(PlainMetric::kYawErrorMean),
                                         MetricId::Plain(PlainMetric::kCadIdentified),
                                         MetricId::Plain(PlainMetric::kLatencyP50),
                                         MetricId::Plain(PlainMetric::kLatencyP90),
                                         MetricId::Plain(PlainMetric::kLatencyP99)};
  for (const MetricId& id : summary) {
    const bool count = std::string(id.Unit()) == "count";
    html << "<tr><td>" << id.Name() << "</td><td>" << Number(MetricOrNan(m, id), count ? 0 : 3)
         << "</td></tr>";
  }
  const double op = OperatingMatchOf(m);
  for (OperatingMeasure measure : EnumValues<OperatingMeasure>()) {
    const MetricId id = MetricId::Operating(std::nullopt, measure, op);
    html << "<tr><td>" << id.Name() << " (at the operating point)</td><td>"
         << Number(MetricOrNan(m, id), measure == OperatingMeasure::kFalsePerFrame ? 2 : 3)
         << "</td></tr>";
  }
  if (run.kind == "external") {
    html << "</table>\n<p>Detections another program wrote (<code>evaluate --detections</code>): "
            "AP sweeps every one; the operating point keeps those at or above the run's "
            "<code>--op-&lt;class&gt;</code> scores (every one without), matched at ";
  } else {
    html << "</table>\n<p>AP sweeps every candidate; the operating point is the model's "
            "per-class least score (<code>workbench model info</code>), what <code>detect</code> "
            "outputs; its detections are matched at ";
  }
  html << Number(op * 100, 0) << " cm.</p>\n<h2>Per class</h2>\n<table><tr><th>class</th>"
       << "<th>objects</th><th>AP@5cm</th><th>AP@10cm</th><th>AP@20cm</th><th>AP3D@0.25</th>"
       << "<th>AP3D@0.50</th><th>precision at the "
          "operating point</th><th>recall at the operating point</th><th>paper best F1</th>"
       << "<th>centre error median (m)</th></tr>";
  for (FurnitureClass c : classes) {
    html << "<tr><td>" << ClassName(c) << "</td><td>" << Number(ClassObjectCount(m, c), 0)
         << "</td>";
    for (double d : kDistances)
      html << "<td>" << Number(MetricOrNan(m, MetricId::ClassAp(c, d))) << "</td>";
    for (double iou : {0.25, 0.5})
      html << "<td>" << Number(MetricOrNan(m, MetricId::IouAp(c, iou, false))) << "</td>";
    for (OperatingMeasure measure : {OperatingMeasure::kPrecision, OperatingMeasure::kRecall})
      html << "<td>" << Number(MetricOrNan(m, MetricId::Operating(c, measure, op))) << "</td>";
    html << "<td>" << Number(MetricOrNan(m, MetricId::PaperBestF1(c))) << "</td><td>"
         << Number(MetricOrNan(m, MetricId::CentreErrorMedian(c))) << "</td></tr>";
  }
  html << "</table>\n<p>AP3D: the 3-D boxes' IoU at 0.25 and 0.5, matched greedily by "
          "score as mmdetection3d does (all-point AP; bird's-eye figures among all metrics "
          "below; \u2013 for a set whose objects have no heights). Centre error: over the "
          "class's objects seen at least "
       << Number(kCentreErrorVisibility * 100, 0)
       << " % (visible share of the pixels in the image times the share of the box in view), "
          "the distance to the nearest detection of the class, a miss counted as "
       << Number(kCentreErrorReachM, 1) << " m.</p>\n";
  return html.str();
}

// Whether the run has protocol A's curves (another program's detections
// have no maxima to sweep).
bool HasPaperCurves(const RunResults& results) {
  for (const auto& [name, curve] : results.curves) {
    if (name.rfind("A/", 0) == 0) return true;
  }
  return false;
}

// What the confusion matrix counts, under it.
std::string ConfusionCaption(const RunResults& results) {
  if (!results.confusion_has_missed || !results.confusion_by_object)
    return "<p>Stored before each object was counted once: a cell counts kept detections, "
           "<i>missed</i> counts objects.</p>";
  return "<p>A row per class of the objects to find, each object counted once: found as its "
         "class (the diagonal), taken by a detection of another class, or missed (no kept "
         "detection within 10 cm); a row's shares add up to its objects, the diagonal's is the "
         "recall at 10 cm. <i>background</i>: kept detections near no object. Not in it: " +
         std::to_string(results.confusion_extra) +
         " kept detections near an object already counted (duplicates) or an ignored one.</p>";
}

// The figures' row and the per-stage latency table.
std::string FiguresHtml(const std::map<std::string, double>& m, const RunResults& results) {
  std::ostringstream html;
  html << "<div class=\"row\"><div><h3>PR, protocol B</h3><img src=\"pr_detection.png\" "
       << "alt=\"protocol B PR curves\"></div><div><h3>PR, protocol A</h3>";
  if (HasPaperCurves(results)) {
    html << "<img src=\"pr_paper.png\" alt=\"protocol A PR curves\">";
  } else {
    html << "<p>Not measured: protocol A sweeps the project's detector's Hough maxima or "
            "learned heat, which another program's detections do not have.</p>";
  }
  html << "</div></div>\n<div class=\"row\"><div><h3>Confusion at the operating point (10 cm)"
       << "</h3><img src=\"confusion.png\" alt=\"confusion matrix\">" << ConfusionCaption(results)
       << "</div><div><h3>Latency</h3>";
  if (m.count(MetricId::Plain(PlainMetric::kLatencyP50).Name())) {
    html << "<img src=\"latency.png\" alt=\"latency histogram\">";
  } else {
    html << "<p>Not given: the detections file has no <code>time_ms</code> for every frame.</p>";
  }
  std::string stages;  // the project's detector's stage medians (none for another program)
  for (const auto& [name, value] : m) {
    const std::optional<MetricId> id = MetricId::TryParse(name);
    if (!id || id->kind() != MetricId::Kind::kStageLatency) continue;
    stages += "<tr><td>" + HtmlEscape(name.substr(8, name.size() - 8 - 7)) + "</td><td>" +
              Number(value, 1) + "</td></tr>";
  }
  if (!stages.empty())
    html << "<table><tr><th>stage</th><th>p50 ms</th></tr>" << stages << "</table>";
  html << "</div></div>\n";
  return html.str();
}

std::string GalleryHtml(const std::vector<GalleryFrame>& gallery) {
  std::ostringstream html;
  html << "<h2>Frames with the most errors</h2>\n<p>Errors of the detections at the operating "
          "point (what <code>detect</code> outputs), at 10 cm. Each frame's 3-D page shows its "
          "points, "
          "the true boxes (red: missed), the detections, the maxima and the learned heat; a "
          "click on a box says what became of it.</p>\n";
  if (gallery.empty())
    html << "<p>No gallery (no frame had an error, or the model file is gone).</p>\n";
  for (const GalleryFrame& g : gallery) {
    html << "<h3>frame " << g.frame_id << ": " << g.false_positives << " false positive(s), "
         << g.false_negatives << " missed &mdash; <a href=\"" << HtmlEscape(g.dir)
         << "/scene.html\">look around in 3-D</a></h3>\n<div class=\"gallery row\">";
    for (const std::string& png : g.pngs) {
      html << "<a href=\"" << HtmlEscape(g.dir + "/" + png) << "\"><img src=\""
           << HtmlEscape(g.dir + "/" + png) << "\" alt=\"" << HtmlEscape(png) << "\"></a>";
    }
    html << "</div>\n";
  }
  return html.str();
}

}  // namespace

void WriteRunReport(const RunReportInput& input, const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  Require(!error, dir + ": cannot create the report directory (" + error.message() + ")");
  auto path = [&](const std::string& name) { return (std::filesystem::path(dir) / name).string(); };
  const RunResults results = ResultsOf(input);
  const std::map<std::string, std::vector<PrPoint>>& curves = results.curves;
  const std::map<std::string, double>& m = input.metrics;
  const std::vector<FurnitureClass> classes =
      ReportedClasses([&](FurnitureClass c) { return HasClassMetrics(m, c); });

  PlotCurves(
      curves, "B/", "@10cm", "protocol B: detections by score, 10 cm", m, path("pr_detection.png"));
  if (HasPaperCurves(results)) {
    PlotCurves(
        curves,
        "A/",
        "",
        "protocol A (paper): maxima (Hough votes or learned heat), 5 cm window, threshold swept",
        m,
        path("pr_paper.png"));
  }
  if (m.count(MetricId::Plain(PlainMetric::kLatencyP50).Name()))
    PlotLatency(input.frame_ms, path("latency.png"));
  PlotConfusion(results, classes, path("confusion.png"));

  std::ostringstream html;
  html << PageHead("Evaluation run", input.run) << SummaryHtml(m, classes, input.run)
       << FiguresHtml(m, results);
  html << ReliabilityHtml(results.calibration,
                          MetricOrNan(m, MetricId::Plain(PlainMetric::kCalibrationError)),
                          path("reliability.png"),
                          "reliability.png");
  html << FunnelHtml(classes, [&](const MetricId& id) { return MetricOrNan(m, id); });
  html << GalleryHtml(input.gallery) << PageTail(input.run, m);
  WriteFileAtomically(path("index.html"), html.str());
}

}  // namespace furn
