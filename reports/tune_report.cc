#include "reports/tune_report.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "reports/chart.h"
#include "reports/evaluation.h"
#include "reports/run_report.h"

namespace furn {
namespace {

// The text as a number when all of it is one (JSON numbers and booleans).
bool AsNumber(const std::string& text, double* value) {
  if (text == "true" || text == "false") {
    *value = text == "true";
    return true;
  }
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size();
}

// Objective against one parameter's values: every trial as a point (the
// base in another colour) and the mean per value as a line. Text values
// (e.g. "rim", "kmeans") are spread over the x axis in sorted order.
void PlotEffect(const TuneReportInput& input, size_t parameter, const std::string& png_path) {
  bool numeric = true;
  std::vector<std::string> labels;
  for (const TuneReportTrial& trial : input.trials) {
    double value;
    numeric = numeric && AsNumber(trial.values[parameter], &value);
    labels.push_back(trial.values[parameter]);
  }
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  auto x_of = [&](const std::string& text) {
    double value = 0;
    if (numeric) {
      AsNumber(text, &value);
      return value;
    }
    return static_cast<double>(std::lower_bound(labels.begin(), labels.end(), text) -
                               labels.begin());
  };
  Chart chart;
  chart.width = 520;
  chart.height = 340;
  chart.title = input.parameters[parameter];
  chart.y.label = input.objective;
  chart.legend = LegendPlace::kBelow;
  chart.empty_note = "no trial has the objective";
  if (!numeric) {
    for (size_t k = 0; k < labels.size(); ++k) chart.x.ticks.emplace_back(k, labels[k]);
  }
  ChartSeries others = MakeSeries("trials", ChartStyle::kPoints, ChartPalette(0));
  ChartSeries base = MakeSeries("base options", ChartStyle::kPoints, ChartPalette(1));
  base.point_scale = 1.6;
  std::map<double, std::pair<double, int>> mean;  // x -> (sum, count)
  for (const TuneReportTrial& trial : input.trials) {
    const double y = MetricOrNan(trial.metrics, MetricId::Parse(input.objective));
    if (std::isnan(y)) continue;
    const double x = x_of(trial.values[parameter]);
    ChartSeries& series = trial.index == 0 ? base : others;
    series.x.push_back(x);
    series.y.push_back(y);
    mean[x].first += y;
    ++mean[x].second;
  }
  // The mean line only where few values repeat often (grids, lists); random
  // draws of a range are (nearly) all different, and their means would zigzag.
  if (2 * mean.size() <= input.trials.size()) {
    ChartSeries line =
        MakeSeries("mean per value", ChartStyle::kLines, ChartColour{0x99, 0x99, 0x99});
    for (const auto& [x, sum_count] : mean) {
      line.x.push_back(x);
      line.y.push_back(sum_count.first / sum_count.second);
    }
    chart.series.push_back(line);
  }
  if (!others.x.empty()) chart.series.push_back(others);
  if (!base.x.empty()) chart.series.push_back(base);
  WriteChartPng(chart, png_path);
}

// The objective of each trial in the order they ran, and the best so far.
void PlotProgress(const TuneReportInput& input, const std::string& png_path) {
  std::vector<std::pair<int, double>> by_index;
  for (const TuneReportTrial& trial : input.trials)
    by_index.emplace_back(trial.index,
                          MetricOrNan(trial.metrics, MetricId::Parse(input.objective)));
  std::sort(by_index.begin(), by_index.end());
  Chart chart;
  chart.width = 520;
  chart.height = 340;
  chart.title = "search progress, by trial";
  chart.x.label = "trial";
  chart.y.label = input.objective;
  chart.legend = LegendPlace::kBelow;
  if (input.trials.size() <= 25) chart.x.tick_step = 1;
  ChartSeries trials = MakeSeries("trial", ChartStyle::kPoints, ChartPalette(0));
  ChartSeries best_so_far = MakeSeries("best so far", ChartStyle::kSteps, ChartPalette(2));
  double best = -1e300;
  for (const auto& [index, value] : by_index) {
    if (!std::isnan(value)) best = std::max(best, value);
    trials.x.push_back(index);
    trials.y.push_back(std::isnan(value) ? 0 : value);
    best_so_far.x.push_back(index);
    best_so_far.y.push_back(best > -1e300 ? best : std::nan(""));
  }
  chart.series = {trials, best_so_far};
  WriteChartPng(chart, png_path);
}

// Rows of headline metrics, base and best side by side per split.
void WriteComparison(const TuneReportInput& input, std::ostringstream* html) {
  std::vector<MetricId> rows = {
      MetricId::MeanAp(0.10), MetricId::MeanAp(0.05), MetricId::MeanAp(0.20)};
  for (FurnitureClass c : kAllClasses) {
    const MetricId ap = MetricId::ClassAp(c, 0.10);
    const bool paper =
        std::find(kPaperClasses.begin(), kPaperClasses.end(), c) != kPaperClasses.end();
    if (paper || input.base_validation.count(ap.Name()) || input.best_validation.count(ap.Name()))
      rows.push_back(ap);
  }
  for (PlainMetric plain : {PlainMetric::kCadIdentified,
                            PlainMetric::kXyErrorMean,
                            PlainMetric::kYawErrorMean,
                            PlainMetric::kLatencyP50})
    rows.push_back(MetricId::Plain(plain));
  const bool test = !input.base_test.empty() || !input.best_test.empty();
  *html << "<table><tr><th>metric</th><th>base, " << HtmlEscape(input.validation_split)
        << "</th><th>best, " << HtmlEscape(input.validation_split) << "</th>";
  if (test) {
    *html << "<th>base, " << HtmlEscape(input.test_split) << "</th><th>best, "
          << HtmlEscape(input.test_split) << "</th><th>change on " << HtmlEscape(input.test_split)
          << "</th>";
  }
  *html << "</tr>\n";
  for (const MetricId& name : rows) {
    // A class's AP with the objects it was measured on (the same for base and best).
    auto cell = [&](const std::map<std::string, double>& metrics) {
      const double value = MetricOrNan(metrics, name);
      if (name.kind() != MetricId::Kind::kClassAp) return Number(value);
      return ApWithObjects(value, ClassObjectCount(metrics, *name.furniture_class()));
    };
    *html << "<tr><td>" << HtmlEscape(name.Name()) << "</td><td>" << cell(input.base_validation)
          << "</td><td>" << cell(input.best_validation) << "</td>";
    if (test) {
      const double base = MetricOrNan(input.base_test, name),
                   best = MetricOrNan(input.best_test, name);
      *html << "<td>" << cell(input.base_test) << "</td><td>" << cell(input.best_test)
            << "</td><td>" << (best - base >= 0 ? "+" : "") << Number(best - base) << "</td>";
    }
    *html << "</tr>\n";
  }
  *html << "</table>\n";
}

}  // namespace

void WriteTuneReport(const TuneReportInput& input, const std::string& dir) {
  Require(!input.trials.empty(), "a tune report needs at least one trial");
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  Require(!error, dir + ": cannot create the report directory (" + error.message() + ")");
  auto path = [&](const std::string& name) { return (std::filesystem::path(dir) / name).string(); };
  PlotProgress(input, path("progress.png"));
  for (size_t p = 0; p < input.parameters.size(); ++p)
    PlotEffect(input, p, path("effect_" + std::to_string(p) + ".png"));

  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>"
       << HtmlEscape(input.title) << "</title>\n<style>body{font-family:sans-serif;margin:24px;"
       << "max-width:1400px}table{border-collapse:collapse;font-size:12px;margin-bottom:16px}"
       << "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#f0f0f0}"
       << "td:first-child,th:first-child{text-align:left}tr.best{background:#e6f4ea;font-weight:"
       << "bold}tr.base{background:#fdecee}tr.over{color:#999}img{border:1px solid #ddd;margin:4px}"
       << "code{background:#f4f4f4;padding:1px 4px}h1,p{overflow-wrap:anywhere}</style></head>"
       << "<body>\n<h1>" << HtmlEscape(input.title) << "</h1>\n";
  for (const std::string& note : input.notes) html << "<p>" << HtmlEscape(note) << "</p>\n";
  html << "<p>Objective: <b>" << HtmlEscape(input.objective)
       << "</b> on the validation split (higher is better; ties go to the earlier trial, the base "
          "first)";
  if (input.max_ms > 0)
    html << "; trials with a median latency above " << Number(input.max_ms, 0)
         << " ms rank last (grey)";
  html << ". Best options: <a href=\"" << HtmlEscape(input.best_options_file) << "\"><code>"
       << HtmlEscape(input.best_options_file) << "</code></a> (trial " << input.best_index
       << ").</p>\n<h2>Best against the base options</h2>\n";
  if (input.best_index == 0) html << "<p>No trial beat the base options: they stay the best.</p>\n";
  WriteComparison(input, &html);

  html << "<h2>Effect of each parameter</h2>\n<div><img src=\"progress.png\" alt=\"progress\">";
  for (size_t p = 0; p < input.parameters.size(); ++p) {
    html << "<img src=\"effect_" << p << ".png\" alt=\"" << HtmlEscape(input.parameters[p])
         << "\">";
  }
  html << "</div>\n<h2>Trials, ranked</h2>\n<table><tr><th>rank</th><th>trial</th><th>run</th>"
       << "<th>" << HtmlEscape(input.objective) << "</th><th>mAP@5cm</th><th>p50 ms</th>"
       << "<th>retrained</th>";
  for (const std::string& name : input.parameters) html << "<th>" << HtmlEscape(name) << "</th>";
  html << "</tr>\n";
  for (size_t rank = 0; rank < input.trials.size(); ++rank) {
    const TuneReportTrial& trial = input.trials[rank];
    const char* css = trial.index == input.best_index ? "best"
                      : trial.index == 0              ? "base"
                      : !trial.within_latency         ? "over"
                                                      : "";
    html << "<tr class=\"" << css << "\"><td>" << rank + 1 << "</td><td>" << trial.index
         << (trial.index == 0 ? " (base)" : "") << "</td><td>" << trial.run_id << "</td><td>"
         << Number(MetricOrNan(trial.metrics, MetricId::Parse(input.objective))) << "</td><td>"
         << Number(MetricOrNan(trial.metrics, MetricId::MeanAp(0.05))) << "</td><td>"
         << Number(MetricOrNan(trial.metrics, MetricId::Plain(PlainMetric::kLatencyP50)), 1)
         << "</td><td>" << (trial.retrained ? "yes" : "no") << "</td>";
    for (const std::string& value : trial.values) html << "<td>" << HtmlEscape(value) << "</td>";
    html << "</tr>\n";
  }
  html << "</table>\n" << ImageCheckHtml() << "</body></html>\n";
  WriteFileAtomically(path("index.html"), html.str());
}

}  // namespace furn
