#include "reports/chart.h"

#include <plplot.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <mutex>

#include "core/util/error.h"
#include "core/util/text.h"

namespace furn {
namespace {

// cmap0 slots: 0 the background, then the fixed inks, then one per series.
enum Ink : PLINT { kBackground = 0, kBlack = 1, kGrid = 2, kGrey = 3, kFirstSeries = 4 };
constexpr PLFLT kTextScale = 0.75;  // of PLplot's default character height
const char* const kDot = "\u25cf";  // the points' symbol

// A finite value on the axis' scale (log10 for a log axis); NaN otherwise.
double Scaled(const ChartAxis& axis, double value) {
  if (!std::isfinite(value) || (axis.log && value <= 0)) return std::nan("");
  return axis.log ? std::log10(value) : value;
}

struct Range {
  double min = std::nan(""), max = std::nan("");
  void Add(double v) {
    if (std::isnan(v)) return;
    min = std::isnan(min) ? v : std::min(min, v);
    max = std::isnan(max) ? v : std::max(max, v);
  }
};

// The axis' window on its scale: the stated bounds, else the data's with a
// margin of 4 % a side; never empty.
Range AxisWindow(const ChartAxis& axis, Range data) {
  if (std::isnan(data.min)) data = {0, 1};
  const double margin = 0.04 * (data.max - data.min);
  Range window{std::isnan(axis.min) ? data.min - margin : Scaled(axis, axis.min),
               std::isnan(axis.max) ? data.max + margin : Scaled(axis, axis.max)};
  if (std::isnan(window.min)) window.min = data.min - margin;
  if (std::isnan(window.max)) window.max = data.max + margin;
  if (!(window.max > window.min)) {
    const double half = std::max(0.5, 0.1 * std::abs(window.min));
    window = {window.min - half, window.min + half};
  }
  return window;
}

struct Windows {
  Range x, y, y2;
};

Windows ChartWindows(const Chart& chart) {
  Range x, y, y2;
  for (const ChartSeries& s : chart.series) {
    Range& values = s.right_axis ? y2 : y;
    const ChartAxis& axis = s.right_axis ? chart.y2 : chart.y;
    for (size_t k = 0; k < std::min(s.x.size(), s.y.size()); ++k) {
      const double sx = Scaled(chart.x, s.x[k]), sy = Scaled(axis, s.y[k]);
      if (std::isnan(sx) || std::isnan(sy)) continue;
      if (s.style == ChartStyle::kBars) {
        x.Add(sx - s.bar_width / 2);
        x.Add(sx + s.bar_width / 2);
        values.Add(axis.log ? sy : 0.0);
      } else {
        x.Add(sx);
      }
      values.Add(sy);
    }
  }
  for (const auto& [value, text] : chart.x.ticks) x.Add(Scaled(chart.x, value));
  return {AxisWindow(chart.x, x), AxisWindow(chart.y, y), AxisWindow(chart.y2, y2)};
}

bool HasPoints(const Chart& chart) {
  for (const ChartSeries& s : chart.series) {
    for (size_t k = 0; k < std::min(s.x.size(), s.y.size()); ++k)
      if (std::isfinite(s.x[k]) && std::isfinite(s.y[k])) return true;
  }
  return false;
}

// The series' points on the chart's scales, cut into runs at every NaN (a
// line is not drawn across a missing value).
std::vector<std::pair<std::vector<PLFLT>, std::vector<PLFLT>>> Runs(const Chart& chart,
                                                                    const ChartSeries& s) {
  const ChartAxis& axis = s.right_axis ? chart.y2 : chart.y;
  std::vector<std::pair<std::vector<PLFLT>, std::vector<PLFLT>>> runs(1);
  for (size_t k = 0; k < std::min(s.x.size(), s.y.size()); ++k) {
    const double sx = Scaled(chart.x, s.x[k]), sy = Scaled(axis, s.y[k]);
    if (std::isnan(sx) || std::isnan(sy)) {
      if (!runs.back().first.empty()) runs.emplace_back();
      continue;
    }
    runs.back().first.push_back(sx);
    runs.back().second.push_back(sy);
  }
  return runs;
}

void DrawLine(const std::vector<PLFLT>& x, const std::vector<PLFLT>& y) {
  if (x.size() >= 2) plline(static_cast<PLINT>(x.size()), x.data(), y.data());
}

void DrawPoints(const std::vector<PLFLT>& x, const std::vector<PLFLT>& y, double scale) {
  if (x.empty()) return;
  plschr(0, kTextScale * scale);
  plstring(static_cast<PLINT>(x.size()), x.data(), y.data(), kDot);
  plschr(0, kTextScale);
}

void DrawSteps(const std::vector<PLFLT>& x, const std::vector<PLFLT>& y) {
  std::vector<PLFLT> sx, sy;
  for (size_t k = 0; k < x.size(); ++k) {
    if (k > 0) {
      sx.push_back(x[k]);
      sy.push_back(y[k - 1]);
    }
    sx.push_back(x[k]);
    sy.push_back(y[k]);
  }
  DrawLine(sx, sy);
}

void DrawBars(const std::vector<PLFLT>& x,
              const std::vector<PLFLT>& y,
              double width,
              double base,
              PLINT ink) {
  for (size_t k = 0; k < x.size(); ++k) {
    PLFLT bx[] = {x[k] - width / 2, x[k] - width / 2, x[k] + width / 2, x[k] + width / 2};
    PLFLT by[] = {base, y[k], y[k], base};
    plcol0(ink);
    plfill(4, bx, by);
    plcol0(kBlack);
    plline(4, bx, by);
  }
}

// Each point's label, centred a little above it.
void DrawPointLabels(const Chart& chart, const ChartSeries& s, const Range& y_window) {
  const ChartAxis& axis = s.right_axis ? chart.y2 : chart.y;
  plcol0(kBlack);
  for (size_t k = 0; k < std::min({s.x.size(), s.y.size(), s.labels.size()}); ++k) {
    const double sx = Scaled(chart.x, s.x[k]), sy = Scaled(axis, s.y[k]);
    if (std::isnan(sx) || std::isnan(sy)) continue;
    plptex(
        sx, sy + 0.03 * (y_window.max - y_window.min), 1, 0, 0.5, ChartText(s.labels[k]).c_str());
  }
}

void DrawSeries(const Chart& chart, const ChartSeries& s, PLINT ink, const Range& y_window) {
  plcol0(ink);
  plwidth(1.5);
  for (const auto& [x, y] : Runs(chart, s)) {
    switch (s.style) {
      case ChartStyle::kLinesPoints:
        DrawLine(x, y);
        DrawPoints(x, y, 0.7 * s.point_scale);
        break;
      case ChartStyle::kLines:
        DrawLine(x, y);
        break;
      case ChartStyle::kDashedLines:
        pllsty(3);
        DrawLine(x, y);
        pllsty(1);
        break;
      case ChartStyle::kPoints:
        DrawPoints(x, y, s.point_scale);
        break;
      case ChartStyle::kSteps:
        DrawSteps(x, y);
        break;
      case ChartStyle::kBars:
        DrawBars(x, y, s.bar_width, std::max(y_window.min, 0.0), ink);
        break;
    }
  }
  plwidth(1);
  if (!s.labels.empty()) DrawPointLabels(chart, s, y_window);
}

// Columns of a legend below the frame: as many as its longest text leaves
// room for (three short ones, one long one).
size_t LegendColumns(const std::vector<std::string>& texts) {
  size_t longest = 0;
  for (const std::string& text : texts) longest = std::max(longest, text.size());
  const size_t columns = longest > 28 ? 1 : longest > 16 ? 2 : 3;
  return std::max<size_t>(1, std::min(columns, texts.size()));
}

// The viewport (normalised page coordinates) leaves room for the legend
// when it is drawn outside the frame.
void SetViewport(const Chart& chart, const std::vector<std::string>& legend_texts) {
  PLFLT left = 0.1, right = chart.with_y2 ? 0.88 : 0.96, bottom = 0.13, top = 0.9;
  if (chart.legend == LegendPlace::kBelow && !legend_texts.empty()) {
    const size_t columns = LegendColumns(legend_texts);
    bottom = 0.12 + 0.045 * static_cast<double>((legend_texts.size() + columns - 1) / columns);
  }
  if (chart.legend == LegendPlace::kRight) right = 0.84;
  plvpor(left, right, bottom, top);
}

// Axis labels with named ticks: the numbers are left out and each tick's
// text is written under the frame at its place.
void DrawNamedTicks(const ChartAxis& axis, const Range& window) {
  plcol0(kBlack);
  for (const auto& [value, text] : axis.ticks) {
    const double at = (Scaled(axis, value) - window.min) / (window.max - window.min);
    if (!(at >= 0 && at <= 1)) continue;
    plmtex("b", 1.6, at, 0.5, ChartText(text).c_str());
  }
}

void DrawFrame(const Chart& chart, const Windows& w) {
  const std::string x_numbers = chart.x.ticks.empty() ? "nst" : "";
  const std::string x_opt = "bc" + x_numbers + (chart.x.log ? "l" : "");
  const std::string y_opt =
      std::string(chart.with_y2 ? "b" : "bc") + "nstv" + (chart.y.log ? "l" : "");
  plwind(w.x.min, w.x.max, w.y.min, w.y.max);
  plcol0(kGrid);
  plbox("g", chart.x.tick_step, 0, "g", chart.y.tick_step, 0);
  plcol0(kBlack);
  plbox(x_opt.c_str(), chart.x.tick_step, 0, y_opt.c_str(), chart.y.tick_step, 0);
  if (!chart.x.ticks.empty()) DrawNamedTicks(chart.x, w.x);
  pllab(ChartText(chart.x.label).c_str(), ChartText(chart.y.label).c_str(), "");
}

void DrawRightAxis(const Chart& chart, const Windows& w) {
  plwind(w.x.min, w.x.max, w.y2.min, w.y2.max);
  plcol0(kBlack);
  const std::string opt = std::string("cmstv") + (chart.y2.log ? "l" : "");
  plbox("", 0, 0, opt.c_str(), chart.y2.tick_step, 0);
  plmtex("r", 3.6, 0.5, 0.5, ChartText(chart.y2.label).c_str());
}

PLINT LegendPosition(LegendPlace place) {
  switch (place) {
    case LegendPlace::kTopLeft:
      return PL_POSITION_TOP | PL_POSITION_LEFT | PL_POSITION_INSIDE;
    case LegendPlace::kTopRight:
      return PL_POSITION_TOP | PL_POSITION_RIGHT | PL_POSITION_INSIDE;
    case LegendPlace::kBottomLeft:
      return PL_POSITION_BOTTOM | PL_POSITION_LEFT | PL_POSITION_INSIDE;
    case LegendPlace::kBottomRight:
      return PL_POSITION_BOTTOM | PL_POSITION_RIGHT | PL_POSITION_INSIDE;
    case LegendPlace::kBelow:
      return PL_POSITION_BOTTOM | PL_POSITION_OUTSIDE;
    case LegendPlace::kRight:
      return PL_POSITION_RIGHT | PL_POSITION_OUTSIDE;
  }
  return PL_POSITION_BOTTOM | PL_POSITION_LEFT | PL_POSITION_INSIDE;
}

// A legend's text of at most kLegendCharacters code points (an ellipsis
// ends a longer one), so that no entry runs off the page.
constexpr size_t kLegendCharacters = 44;

std::string Shortened(const std::string& text) {
  const std::string valid = ValidUtf8(text);
  size_t characters = 0;
  for (size_t at = 0; at < valid.size(); ++at) {
    if ((static_cast<unsigned char>(valid[at]) & 0xC0) == 0x80) continue;  // a continuation
    if (++characters > kLegendCharacters) return valid.substr(0, at) + "\u2026";
  }
  return valid;
}

// The legend's entries: one per titled series, its ink, style and text.
struct LegendEntries {
  std::vector<std::string> texts;
  std::vector<PLINT> options, inks, ones, patterns, styles;
  std::vector<PLFLT> scales, widths;
  std::vector<const char*> symbols;
};

LegendEntries MakeLegend(const Chart& chart) {
  LegendEntries entries;
  for (size_t k = 0; k < chart.series.size(); ++k) {
    const ChartSeries& s = chart.series[k];
    if (s.title.empty()) continue;
    entries.texts.push_back(ChartText(Shortened(s.title)));
    PLINT option = PL_LEGEND_LINE;
    if (s.style == ChartStyle::kPoints) option = PL_LEGEND_SYMBOL;
    if (s.style == ChartStyle::kLinesPoints) option = PL_LEGEND_LINE | PL_LEGEND_SYMBOL;
    if (s.style == ChartStyle::kBars) option = PL_LEGEND_COLOR_BOX;
    entries.options.push_back(option);
    entries.inks.push_back(kFirstSeries + static_cast<PLINT>(k));
    entries.ones.push_back(1);
    entries.patterns.push_back(0);
    entries.styles.push_back(s.style == ChartStyle::kDashedLines ? 3 : 1);
    entries.scales.push_back(s.style == ChartStyle::kLinesPoints ? 0.7 * s.point_scale
                                                                 : s.point_scale);
    entries.widths.push_back(1.5);
    entries.symbols.push_back(kDot);
  }
  return entries;
}

void DrawLegend(const Chart& chart) {
  LegendEntries e = MakeLegend(chart);
  if (e.texts.empty()) return;
  std::vector<const char*> texts;
  for (const std::string& text : e.texts) texts.push_back(text.c_str());
  const PLINT n = static_cast<PLINT>(texts.size());
  const bool below = chart.legend == LegendPlace::kBelow;
  const PLINT columns = below ? static_cast<PLINT>(LegendColumns(e.texts)) : 1;
  const PLINT rows = (n + columns - 1) / columns;
  std::vector<PLINT> text_inks(texts.size(), kBlack);
  PLFLT width = 0, height = 0;
  // Below the frame, under the x axis' label: 10.5 % of the page down, in
  // the viewport's units that pllegend takes.
  PLFLT page_left = 0, page_right = 1, page_bottom = 0, page_top = 1;
  plgvpd(&page_left, &page_right, &page_bottom, &page_top);
  const PLFLT below_offset = 0.105 / std::max<PLFLT>(page_top - page_bottom, 0.1);
  plwind(0, 1, 0, 1);
  pllegend(&width,
           &height,
           PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX | PL_LEGEND_ROW_MAJOR,
           LegendPosition(chart.legend),
           0.01,
           below ? below_offset : 0.01,
           0.06,
           kBackground,
           kGrey,
           1,
           rows,
           columns,
           n,
           e.options.data(),
           0.8,
           0.8,
           1.8,
           0,
           text_inks.data(),
           texts.data(),
           e.inks.data(),
           e.patterns.data(),
           e.scales.data(),
           e.widths.data(),
           e.inks.data(),
           e.styles.data(),
           e.widths.data(),
           e.inks.data(),
           e.scales.data(),
           e.ones.data(),
           e.symbols.data());
}

void SetInks(const Chart& chart) {
  plscmap0n(kFirstSeries + static_cast<PLINT>(chart.series.size()));
  plscol0(kBackground, 255, 255, 255);
  plscol0(kBlack, 0, 0, 0);
  plscol0(kGrid, 0xdd, 0xdd, 0xdd);
  plscol0(kGrey, 0x99, 0x99, 0x99);
  for (size_t k = 0; k < chart.series.size(); ++k) {
    const ChartColour c = chart.series[k].colour;
    plscol0(kFirstSeries + static_cast<PLINT>(k), c.r, c.g, c.b);
  }
}

bool HasPngCairo() {
  // The caller owns the arrays; `count` is their size in, the devices out.
  std::vector<const char*> menu_storage(256, nullptr), name_storage(256, nullptr);
  const char** menus = menu_storage.data();
  const char** names = name_storage.data();
  int count = static_cast<int>(name_storage.size());
  plgDevs(&menus, &names, &count);
  for (int k = 0; k < count; ++k)
    if (std::string(names[k]) == "pngcairo") return true;
  return false;
}

void DrawChart(const Chart& chart) {
  const Windows w = ChartWindows(chart);
  pladv(0);
  // The title centred on the page (a legend beside the frame would push it
  // off the page's left edge if it were centred on the frame).
  plvpor(0.02, 0.98, 0.1, 0.9);
  plschr(0, 1.15 * kTextScale);
  plmtex("t", 1.0, 0.5, 0.5, ChartText(chart.title).c_str());
  SetViewport(chart, MakeLegend(chart).texts);
  plschr(0, kTextScale);
  DrawFrame(chart, w);
  if (!HasPoints(chart)) {
    plwind(0, 1, 0, 1);
    plcol0(kBlack);
    plptex(0.5, 0.5, 1, 0, 0.5, ChartText(chart.empty_note).c_str());
    return;
  }
  for (size_t k = 0; k < chart.series.size(); ++k) {
    const ChartSeries& s = chart.series[k];
    if (s.right_axis) continue;
    DrawSeries(chart, s, kFirstSeries + static_cast<PLINT>(k), w.y);
  }
  if (chart.with_y2) {
    DrawRightAxis(chart, w);
    for (size_t k = 0; k < chart.series.size(); ++k) {
      if (chart.series[k].right_axis)
        DrawSeries(chart, chart.series[k], kFirstSeries + static_cast<PLINT>(k), w.y2);
    }
  }
  DrawLegend(chart);
}

}  // namespace

ChartColour ChartPalette(size_t k) {
  static const ChartColour kBright[] = {{0x44, 0x77, 0xaa},
                                        {0xee, 0x66, 0x77},
                                        {0x22, 0x88, 0x33},
                                        {0xcc, 0xbb, 0x44},
                                        {0x66, 0xcc, 0xee},
                                        {0xaa, 0x33, 0x77},
                                        {0x77, 0x77, 0x77}};
  return kBright[k % (sizeof(kBright) / sizeof(kBright[0]))];
}

std::string ChartText(const std::string& text) {
  std::string out;
  for (char c : PrintableText(text)) {
    out += c;
    if (c == '#') out += '#';  // PLplot's escape character, drawn as itself
  }
  return out;
}

void WriteChartPng(const Chart& chart, const std::string& png_path) {
  Require(chart.width >= 64 && chart.width <= 4096 && chart.height >= 64 && chart.height <= 4096,
          png_path + ": a chart is 64..4096 px a side");
  // PLplot keeps global state: one chart at a time.
  static std::mutex mutex;
  const std::lock_guard<std::mutex> lock(mutex);
  Require(HasPngCairo(),
          png_path +
              ": PLplot's cairo driver is missing (apt install "
              "plplot-driver-cairo)");
  const std::string temporary = png_path + ".partial-" + std::to_string(getpid());
  // PLplot exits the process when it cannot open its output: open it first.
  std::FILE* probe = std::fopen(temporary.c_str(), "wb");
  Require(probe != nullptr, png_path + ": cannot write the chart");
  std::fclose(probe);
  PLINT stream = 0;
  plmkstrm(&stream);
  plsdev("pngcairo");
  plsfnam(temporary.c_str());
  const std::string geometry = std::to_string(chart.width) + "x" + std::to_string(chart.height);
  plsetopt("geometry", geometry.c_str());
  SetInks(chart);
  plinit();
  DrawChart(chart);
  plend1();
  std::error_code error;
  if (std::filesystem::file_size(temporary, error) == 0 || error) {
    std::filesystem::remove(temporary, error);
    throw InputError(png_path + ": PLplot wrote no chart");
  }
  std::filesystem::rename(temporary, png_path, error);
  if (error) std::filesystem::remove(temporary);
  Require(!error, png_path + ": cannot write (" + error.message() + ")");
}

}  // namespace furn
