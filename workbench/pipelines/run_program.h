// Runs another program (squeue, sbatch, git) with an argument vector and no
// shell, so nothing in its arguments is ever interpreted, and captures what
// it prints.
//
//   const ProgramResult git = RunProgram({"git", "-C", dir, "rev-parse", "HEAD"});
//   if (git.exit_code == 0) commit = git.output;
#pragma once

#include <string>
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

 private:
  int pid_ = -1;
};

}  // namespace furn
