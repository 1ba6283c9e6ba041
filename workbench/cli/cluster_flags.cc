#include "workbench/cli/cluster_flags.h"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>

#include "core/util/error.h"

namespace furn {
namespace {

// Cluster flags that take a value, and those that do not.
const std::set<std::string> kWithValue = {
    "--shards", "--job-dir", "--partition", "--time", "--mem", "--cpus"};
const std::set<std::string> kWithoutValue = {"--slurm", "--emit-only"};

std::string SelfPath() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  Require(!ec, "cannot find this program's own path (/proc/self/exe)");
  return self.string();
}

}  // namespace

void ClusterFlags::Check() const {
  if (!Active()) {
    Require(!slurm && !emit_only,
            "--slurm and --emit-only need --shards N (train: or --vote-workers N)");
    return;
  }
  // The final step names every shard's file on one command line: 10^4 stay
  // well inside the kernel's limit on a command's arguments.
  Require(shards <= 10000, "--shards " + std::to_string(shards) + " must be in 1..10000");
  Require(slurm != emit_only, "--shards needs exactly one of --slurm (submit) and --emit-only");
  Require(!job_dir.empty(), "--shards needs --job-dir (a folder every node sees)");
  resources.Check();
}

void AddClusterFlags(CLI::App* app, ClusterFlags* flags) {
  app->add_option("--shards",
                  flags->shards,
                  "Run as a Slurm array job of N tasks (one shard each) and a final merge")
      ->capture_default_str();
  // train takes them with --vote-workers N too (a one-task array job
  // makes the rooms), so the help names both.
  app->add_flag("--slurm",
                flags->slurm,
                "With --shards (train: or --vote-workers N): submit the array job (sbatch)");
  app->add_flag("--emit-only",
                flags->emit_only,
                "With --shards (train: or --vote-workers N): write the sbatch scripts and print "
                "the commands, submit nothing");
  app->add_option("--job-dir",
                  flags->job_dir,
                  "With --shards (train: or --vote-workers N --slurm): the job folder (shared "
                  "filesystem)");
  app->add_option("--partition", flags->resources.partition, "Slurm partition");
  app->add_option("--time", flags->resources.time, "Slurm time limit per task (e.g. 1:00:00)");
  app->add_option("--mem", flags->resources.mem, "Slurm memory per task (e.g. 4G)");
  app->add_option("--cpus", flags->resources.cpus, "Slurm CPUs per task")->capture_default_str();
}

std::string TaskCommandLine(int argc,
                            char** argv,
                            const std::set<std::string>& drop,
                            const std::string& append) {
  std::string line = ShellQuote(SelfPath()) + " " + ShellQuote(argv[0]);
  for (int k = 1; k < argc; ++k) {
    const std::string argument = argv[k];
    const std::string name = argument.substr(0, argument.find('='));
    const bool has_inline_value = name.size() < argument.size();
    if (kWithoutValue.count(argument)) continue;
    if (kWithValue.count(name) || drop.count(name)) {
      if (!has_inline_value) ++k;  // its value
      continue;
    }
    line += " " + ShellQuote(argument);
  }
  return line + " " + append;
}

std::string WorkbenchCommand(const std::string& arguments) {
  return ShellQuote(SelfPath()) + " " + arguments;
}

ArrayJob NewArrayJob(const ClusterFlags& flags, const std::string& name) {
  ArrayJob job;
  job.dir = flags.job_dir;
  job.name = name;
  job.tasks = flags.shards;
  job.resources = flags.resources;
  return job;
}

std::string TaskShardArgument(const ArrayJob& job) {
  return "\"$TASK\"/" + std::to_string(job.tasks);
}

void SetTaskOutput(ArrayJob* job, const std::string& stem, const std::string& extension) {
  job->task_output =
      std::filesystem::absolute(job->dir).string() + "/" + stem + "$TASK" + extension;
}

std::string TaskOutputArgument(const ArrayJob& job) {
  const size_t at = job.task_output.find("$TASK");
  return ShellQuote(job.task_output.substr(0, at)) + "\"$TASK\"" +
         ShellQuote(job.task_output.substr(at + 5));
}

std::string AllTaskOutputs(const ArrayJob& job) {
  const size_t at = job.task_output.find("$TASK");
  std::string files;
  for (int k = 0; k < job.tasks; ++k) {
    files += " " + ShellQuote(job.task_output.substr(0, at) + std::to_string(k) +
                              job.task_output.substr(at + 5));
  }
  return files;
}

int RunArrayJob(const ClusterFlags& flags, const ArrayJob& job) {
  if (flags.emit_only) {
    const std::vector<std::string> commands = EmitArrayJob(job);
    std::printf("%s: scripts written; submit with:\n", job.dir.c_str());
    for (const std::string& command : commands) std::printf("  %s\n", command.c_str());
    if (commands.empty()) std::printf("  (nothing: every task and the final step are done)\n");
    return 0;
  }
  const Submission submission = SubmitArrayJob(job);
  if (submission.array_job_id.empty() && submission.final_job_id.empty()) {
    std::printf("%s: every task and the final step are done; nothing submitted\n", job.dir.c_str());
    return 0;
  }
  if (!submission.array_job_id.empty()) {
    std::printf("submitted array job %s: %zu of %d tasks\n",
                submission.array_job_id.c_str(),
                submission.tasks.size(),
                job.tasks);
  }
  if (!submission.final_job_id.empty())
    std::printf("submitted final job %s (after the tasks succeed)\n",
                submission.final_job_id.c_str());
  std::printf("follow with: workbench jobs status %s   (or: workbench jobs wait %s)\n",
              job.dir.c_str(),
              job.dir.c_str());
  return 0;
}

}  // namespace furn
