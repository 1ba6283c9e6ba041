// Internal to reports/: the figures' charts (PR curves, history, reliability,
// bars, histograms, tuning scatter, training curves) drawn in-process by
// PLplot's cairo driver into a PNG. No program is fed a script: every text
// of a chart (a run's kind, a dataset's file name) is data, made valid UTF-8,
// its control characters made visible and PLplot's escape character doubled
// before it is drawn.
//
//   Chart chart;
//   chart.title = "PR, protocol B";
//   chart.x = MakeAxis("recall", 0, 1);
//   chart.y = MakeAxis("precision", 0, 1.02);
//   chart.series.push_back(
//       MakeSeries("chair (12 objects)", ChartStyle::kLines, ChartPalette(0), recall, precision));
//   WriteChartPng(chart, "pr.png");
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace furn {

struct ChartColour {
  uint8_t r = 0x44, g = 0x77, b = 0xaa;
};

// The palette the figures share (colour-blind safe, Paul Tol's "bright").
ChartColour ChartPalette(size_t k);

enum class ChartStyle {
  kLinesPoints,  // a line through the points, a dot at each
  kLines,
  kDashedLines,
  kPoints,
  kSteps,  // a staircase: the value holds until the next x
  kBars,   // a bar from 0 (or the axis' bottom) to y, `bar_width` wide in x
};

struct ChartSeries {
  std::string title;  // the legend's text; empty: not in the legend
  std::vector<double> x, y;
  ChartStyle style = ChartStyle::kLinesPoints;
  ChartColour colour;
  double bar_width = 1;  // x units, kBars only
  double point_scale = 1;
  bool right_axis = false;          // plotted against Chart::y2
  std::vector<std::string> labels;  // text above each point (empty: none)
};

struct ChartAxis {
  std::string label;
  double min = std::nan("");  // NaN: from the data, with a margin
  double max = std::nan("");
  bool log = false;  // a log10 scale (positive values only)
  // Named ticks (value, text), e.g. categories; empty: numbers.
  std::vector<std::pair<double, std::string>> ticks;
  double tick_step = 0;  // numbers' spacing; 0: chosen by PLplot
};

inline ChartSeries MakeSeries(std::string title,
                              ChartStyle style,
                              ChartColour colour,
                              std::vector<double> x = {},
                              std::vector<double> y = {}) {
  ChartSeries series;
  series.title = std::move(title);
  series.style = style;
  series.colour = colour;
  series.x = std::move(x);
  series.y = std::move(y);
  return series;
}

inline ChartAxis MakeAxis(std::string label, double min = std::nan(""), double max = std::nan("")) {
  ChartAxis axis;
  axis.label = std::move(label);
  axis.min = min;
  axis.max = max;
  return axis;
}

enum class LegendPlace { kTopLeft, kTopRight, kBottomLeft, kBottomRight, kBelow, kRight };

struct Chart {
  std::string title;
  int width = 640;  // px
  int height = 420;
  ChartAxis x, y;
  bool with_y2 = false;
  ChartAxis y2;
  std::vector<ChartSeries> series;
  LegendPlace legend = LegendPlace::kBottomLeft;
  std::string empty_note = "no data";  // drawn in the middle when no series has a point
};

// Text as a chart draws it: valid UTF-8, control characters written as
// escapes (PrintableText), PLplot's escape character '#' doubled.
std::string ChartText(const std::string& text);

// Draws `chart` into `png_path` (written atomically). Throws InputError
// naming the file when it cannot be written or PLplot's driver is missing.
void WriteChartPng(const Chart& chart, const std::string& png_path);

}  // namespace furn
