#include "workbench/pipelines/run_record.h"

#include <ctime>

#include "workbench/pipelines/run_program.h"

namespace furn {
namespace {

// What `git -C <source dir> args...` prints, without its trailing newline;
// empty when git is missing or fails (not a checkout).
std::string GitOutput(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {"git", "-C", FURN_SOURCE_DIR};
  argv.insert(argv.end(), args.begin(), args.end());
  ProgramResult git = RunProgram(argv, false);
  if (git.exit_code != 0) return "";
  while (!git.output.empty() && (git.output.back() == '\n' || git.output.back() == '\r'))
    git.output.pop_back();
  return git.output;
}

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

}  // namespace

RunRecord NewRunRecord(const std::string& kind, const std::string& label) {
  RunRecord run;
  run.kind = kind;
  run.label = label;
  run.started = UtcNow();
  run.git_commit = GitOutput({"rev-parse", "HEAD"});
  if (run.git_commit.empty()) run.git_commit = "unknown";
  run.git_dirty = !GitOutput({"status", "--porcelain", "--untracked-files=no"}).empty();
  return run;
}

}  // namespace furn
