#include "core/util/progress.h"

#include <cstring>

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace furn {
namespace {

bool g_quiet = false;
double g_log_interval_s = 60;

std::string FormatSeconds(double seconds) {
  char text[32];
  const int s = static_cast<int>(seconds + 0.5);
  if (s >= 3600) {
    std::snprintf(text, sizeof(text), "%dh%02dm", s / 3600, (s / 60) % 60);
  } else {
    std::snprintf(text, sizeof(text), "%dm%02ds", s / 60, s % 60);
  }
  return text;
}

}  // namespace

void Progress::SetQuiet(bool quiet) { g_quiet = quiet; }

bool Progress::Quiet() { return g_quiet; }

void Progress::SetLogInterval(double seconds) { g_log_interval_s = seconds; }

Progress::Progress(std::string label, size_t total, std::string unit)
    : label_(std::move(label)),
      total_(total),
      unit_(std::move(unit)),
      on_terminal_(::isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

Progress::~Progress() { Finish(); }

void Progress::Advance(size_t steps) {
  done_ = std::min(total_, done_ + steps);
  Draw(false);
}

void Progress::AddSecondary(size_t count, const std::string& unit) {
  secondary_ += count;
  secondary_unit_ = unit;
}

void Progress::Finish() {
  if (finished_) return;
  finished_ = true;
  Draw(true);
}

void Progress::SetNote(std::string note) { note_ = std::move(note); }

void Progress::Draw(bool final_line) {
  if (g_quiet || total_ == 0) return;
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double rate = elapsed > 0 ? done_ / elapsed : 0.0;
  const double eta = rate > 0 ? (total_ - done_) / rate : 0.0;
  const double fraction = static_cast<double>(done_) / total_;
  char secondary[128] = "";
  if (!secondary_unit_.empty() && elapsed > 0) {
    std::snprintf(
        secondary, sizeof(secondary), ", %.1f %s/s", secondary_ / elapsed, secondary_unit_.c_str());
  }
  if (!note_.empty()) {
    const size_t used = std::strlen(secondary);
    std::snprintf(secondary + used, sizeof(secondary) - used, ", %s", note_.c_str());
  }
  if (on_terminal_) {
    if (!final_line && now - last_draw_ < std::chrono::milliseconds(100)) return;
    last_draw_ = now;
    constexpr int kWidth = 30;
    std::string bar(static_cast<size_t>(fraction * kWidth), '#');
    bar.resize(kWidth, '-');
    std::fprintf(stderr,
                 "\r%s [%s] %zu/%zu %s  %.1f %s/s%s  ETA %s   ",
                 label_.c_str(),
                 bar.c_str(),
                 done_,
                 total_,
                 unit_.c_str(),
                 rate,
                 unit_.c_str(),
                 secondary,
                 FormatSeconds(eta).c_str());
    if (final_line) std::fputc('\n', stderr);
    return;
  }
  const int decile = static_cast<int>(fraction * 10);
  const bool interval_passed =
      std::chrono::duration<double>(now - last_draw_).count() >= g_log_interval_s &&
      done_ != last_logged_done_;
  if (!final_line && decile == last_logged_decile_ && !interval_passed) return;
  if (final_line && done_ == last_logged_done_) return;
  last_logged_decile_ = decile;
  last_logged_done_ = done_;
  last_draw_ = now;
  std::fprintf(stderr,
               "%s: %zu/%zu %s (%.0f%%), %.1f %s/s%s, elapsed %s, ETA %s\n",
               label_.c_str(),
               done_,
               total_,
               unit_.c_str(),
               100 * fraction,
               rate,
               unit_.c_str(),
               secondary,
               FormatSeconds(elapsed).c_str(),
               FormatSeconds(eta).c_str());
}

}  // namespace furn
