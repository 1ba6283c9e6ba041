// Progress of long work on stderr: a redrawn bar with rate and ETA on a
// terminal, plain log lines otherwise (one per 10 %, and one at least every
// minute of long work), nothing when quiet.
//
//   Progress progress("import", entries.size(), "models");
//   for (...) { ...; progress.Advance(); }
//   progress.Finish();
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace furn {

class Progress {
 public:
  Progress(std::string label, size_t total, std::string unit);
  ~Progress();

  void Advance(size_t steps = 1);
  // A second count shown as a rate beside the main one (e.g. frames beside rooms).
  void AddSecondary(size_t count, const std::string& unit);
  // A short note shown after the counts (e.g. "loss 0.412"), until replaced.
  void SetNote(std::string note);
  void Finish();

  // Set once by the CLI (--quiet); applies to every Progress.
  static void SetQuiet(bool quiet);
  static bool Quiet();
  // The longest time between two log lines (seconds; 60 unless set, for tests).
  static void SetLogInterval(double seconds);

 private:
  void Draw(bool final_line);

  std::string label_;
  size_t total_;
  std::string unit_;
  size_t done_ = 0;
  size_t secondary_ = 0;
  std::string secondary_unit_;
  std::string note_;
  bool on_terminal_;
  bool finished_ = false;
  int last_logged_decile_ = -1;
  size_t last_logged_done_ = static_cast<size_t>(-1);
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace furn
