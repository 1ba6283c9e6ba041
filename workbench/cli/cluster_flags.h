// Running a sharded command as a Slurm array job (issue 31): --shards N with
// --slurm (submit) or --emit-only (write the scripts), --job-dir and the
// resources. Shared by the commands that shard.
#pragma once

#include <set>
#include <string>
#include <vector>

#include "workbench/pipelines/slurm_jobs.h"

namespace CLI {
class App;
}

namespace furn {

struct ClusterFlags {
  int shards = 0;  // 0: run here, in this process
  bool slurm = false;
  bool emit_only = false;
  std::string job_dir;
  SlurmResources resources;

  bool Active() const { return shards > 0; }
  // Throws InputError when the flags do not go together.
  void Check() const;
};

// --shards, --slurm, --emit-only, --job-dir, --partition, --time, --mem, --cpus.
void AddClusterFlags(CLI::App* app, ClusterFlags* flags);

// This command's own command line for one task: the absolute path of this
// binary, the command (argv[0]), then argv[1..] without the cluster flags and without `drop` (flags
// with a value, e.g. --out), each shell-quoted; `append` added at the end
// (already quoted where needed).
std::string TaskCommandLine(int argc,
                            char** argv,
                            const std::set<std::string>& drop,
                            const std::string& append);

// This binary with `arguments` (already quoted), e.g. "dataset merge ...".
std::string WorkbenchCommand(const std::string& arguments);

// A job of flags.shards tasks named `name` in the job folder, with the
// flags' resources; its commands and outputs still to fill in.
ArrayJob NewArrayJob(const ClusterFlags& flags, const std::string& name);

// "$TASK"/N: the shard a task makes, as its script passes it.
std::string TaskShardArgument(const ArrayJob& job);

// Sets the job's task output to DIR/<stem><i><extension> in the job folder
// (what a rerun looks for); TaskOutputArgument is that file as a task's
// script names it (quoted around "$TASK"), AllTaskOutputs the files of
// tasks 0..N-1, each quoted after a space (the final job's arguments).
void SetTaskOutput(ArrayJob* job, const std::string& stem, const std::string& extension);
std::string TaskOutputArgument(const ArrayJob& job);
std::string AllTaskOutputs(const ArrayJob& job);

// Submits (--slurm) or writes (--emit-only) the job and prints what it did.
int RunArrayJob(const ClusterFlags& flags, const ArrayJob& job);

}  // namespace furn
