// Runs another program (squeue, sbatch, git) with an argument vector and no
// shell, so nothing in its arguments is ever interpreted, and captures what
// it prints.
//
//   const ProgramResult git = RunProgram({"git", "-C", dir, "rev-parse", "HEAD"});
//   if (git.exit_code == 0) commit = git.output;
#pragma once

#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace furn {

struct ProgramResult {
  std::string output;  // standard output (and error, when asked), at most kMaxCapture bytes
  int exit_code = 0;   // 127: not found; 128: killed by a signal
};

constexpr size_t kMaxCapture = 16u << 20;

// Runs argv[0] (looked up in PATH) with argv; standard error goes with the
// output when `with_stderr`, else to /dev/null. Throws InputError only when
// no pipe can be made.
ProgramResult RunProgram(const std::vector<std::string>& argv, bool with_stderr = true);

// A program started and left running, its output (and error) appended to
// `log_path`: e.g. the other ranks of a data-parallel training. Not waited
// for, it is stopped (SIGTERM) and reaped when the object goes. Throws
// InputError when it cannot be started or the log not opened.
class RunningProgram {
 public:
  RunningProgram(const std::vector<std::string>& argv, const std::string& log_path);
  ~RunningProgram();
  RunningProgram(const RunningProgram&) = delete;
  RunningProgram& operator=(const RunningProgram&) = delete;
  // Its exit code (128: killed by a signal).
  int Wait();
  // Its exit code when it has ended, without waiting; empty while it runs.
  std::optional<int> Poll();
  // Stops it (SIGTERM) and reaps it.
  void Stop();

 private:
  int pid_ = -1;
  std::optional<int> exit_code_;
};

// Watches running programs from a thread of its own (every `period_s`):
// the first that ends with a non-zero exit code is handed to `failed` (its
// index), once, on that thread; e.g. rank 0 of a data-parallel training
// stops at once when a worker dies instead of waiting for the group's
// timeout. Stopped (joined) by Stop or the destructor; the programs outlive
// the watch.
class ProgramWatch {
 public:
  ProgramWatch(std::vector<RunningProgram*> programs,
               std::function<void(size_t)> failed,
               double period_s = 0.5);
  ~ProgramWatch();
  ProgramWatch(const ProgramWatch&) = delete;
  ProgramWatch& operator=(const ProgramWatch&) = delete;
  void Stop();

 private:
  std::vector<RunningProgram*> programs_;
  std::function<void(size_t)> failed_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace furn
