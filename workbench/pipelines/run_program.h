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

}  // namespace furn
