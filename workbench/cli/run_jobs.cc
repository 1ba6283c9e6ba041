// `workbench jobs status|wait|cancel DIR`: a Slurm array job's folder (issue 31).
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <thread>

#include "core/util/error.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/commands.h"
#include "workbench/pipelines/slurm_jobs.h"

namespace furn {
namespace {

std::string Who(const TaskState& t) {
  return t.task < 0 ? std::string("final") : "task " + std::to_string(t.task);
}

void PrintState(const std::string& dir, const JobFolderState& state) {
  std::printf("%s: %s job, %zu tasks\n",
              dir.c_str(),
              state.name.c_str(),
              state.tasks.empty() ? 0 : state.tasks.size() - (state.tasks.back().task < 0));
  for (const TaskState& t : state.tasks)
    std::printf("  %-8s %s\n", Who(t).c_str(), t.state.c_str());
  std::printf("%s\n",
              state.finished ? "finished"
              : state.failed ? "failed: rerun the same command to resubmit what is missing"
                             : "in progress");
}

// One line: how many tasks are in each state.
std::string Counts(const JobFolderState& state) {
  std::map<std::string, int> counts;
  for (const TaskState& t : state.tasks) {
    if (t.task >= 0) ++counts[t.state.substr(0, t.state.find(' '))];
  }
  std::string line;
  for (const auto& [name, n] : counts)
    line += (line.empty() ? "" : ", ") + std::to_string(n) + " " + name;
  const std::string final_state =
      !state.tasks.empty() && state.tasks.back().task < 0 ? state.tasks.back().state : "-";
  return line + "; final: " + final_state;
}

}  // namespace

int RunJobs(int argc, char** argv) {
  CLI::App app{"State of a Slurm array job's folder, wait until it finishes, or cancel it",
               "workbench jobs"};
  app.require_subcommand(1);
  std::string dir;
  double timeout_s = 0, poll_s = 2;
  bool quiet = false;
  CLI::App* status =
      app.add_subcommand("status", "Each task's state: done, failed, queued, running, missing");
  status->add_option("dir", dir, "Job folder (--job-dir)")->required();
  CLI::App* wait = app.add_subcommand(
      "wait", "Wait until every task and the final step are done (exit 0) or one failed (exit 1)");
  wait->add_option("dir", dir, "Job folder (--job-dir)")->required();
  wait->add_option("--timeout", timeout_s, "Give up after S seconds (exit 1; 0: never)")
      ->capture_default_str();
  wait->add_option("--poll", poll_s, "Seconds between looks")->capture_default_str();
  wait->add_flag("-q,--quiet", quiet, "Only the last line");
  CLI::App* cancel = app.add_subcommand(
      "cancel", "scancel every job of the folder (a rerun of the command resubmits what is left)");
  cancel->add_option("dir", dir, "Job folder (--job-dir)")->required();
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  if (cancel->parsed()) {
    const std::vector<std::string> ids = CancelJobs(dir);
    std::string list;
    for (const std::string& id : ids) list += (list.empty() ? "" : ", ") + id;
    std::printf("%s: %s\n",
                dir.c_str(),
                ids.empty() ? "nothing was submitted" : ("cancelled jobs " + list).c_str());
    return 0;
  }
  if (status->parsed()) {
    const JobFolderState state = ReadJobFolder(dir);
    PrintState(dir, state);
    return state.failed ? 1 : 0;
  }
  Require(timeout_s >= 0 && poll_s > 0 && poll_s <= 3600,
          "--timeout must be >= 0 and --poll in (0, 3600] s");
  const auto start = std::chrono::steady_clock::now();
  std::string last;
  for (;;) {
    const JobFolderState state = ReadJobFolder(dir);
    const std::string line = Counts(state);
    if (!quiet && line != last) std::fprintf(stderr, "jobs: %s\n", line.c_str());
    last = line;
    if (state.finished) {
      std::printf("%s: finished\n", dir.c_str());
      return 0;
    }
    if (state.failed) {
      std::string which;
      for (const TaskState& t : state.tasks) {
        if (t.state.rfind("failed", 0) == 0 || t.state == "missing")
          which += (which.empty() ? "" : ", ") + Who(t) + " " + t.state;
      }
      std::printf("%s: failed (%s); logs in %s/logs; rerun the same command to resubmit\n",
                  dir.c_str(),
                  which.c_str(),
                  dir.c_str());
      return 1;
    }
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (timeout_s > 0 && waited > timeout_s) {
      std::printf("%s: still in progress after %.0f s (%s)\n", dir.c_str(), waited, line.c_str());
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(poll_s));
  }
}

}  // namespace furn
