// Slurm array jobs (issue 31): a sharded command as one array job, a task per
// shard, and a final job that runs after every task succeeded (afterok), e.g.
// the merge. The tasks share nothing but the job folder (a shared filesystem):
//
//   DIR/task.sbatch, DIR/final.sbatch   the scripts (written before any submission)
//   DIR/jobs.json                       the command, the tasks and every submission
//   DIR/logs/task-<i>.log, final.log    each task's output
//   DIR/status/task-<i>.ok | .failed    each task's exit status (written by the script)
//
// A rerun of the same command resubmits only the tasks that are not done
// (no .ok, or their output missing); a task still queued or running is not
// submitted twice.
#pragma once

#include <string>
#include <vector>

namespace furn {

struct SlurmResources {
  std::string partition;  // empty: the cluster's default
  std::string time;       // sbatch --time, e.g. "2:00:00"; empty: the partition's limit
  std::string mem;        // sbatch --mem, e.g. "4G"; empty: the cluster's default
  int cpus = 2;           // --cpus-per-task

  // Throws InputError naming the flag and the rule.
  void Check() const;
};

struct ArrayJob {
  std::string dir;   // the job folder
  std::string name;  // "generate", "evaluate", ...: the job names and jobs.json
  int tasks = 1;
  // One shell command per task, the index as $TASK (0 .. tasks - 1).
  std::string task_command;
  // A task is done when its .ok exists and so does this file ("$TASK"
  // replaced by the index; empty: the .ok alone).
  std::string task_output;
  std::string final_command;  // run once every task succeeded; empty: none
  std::string final_output;   // the final job is done when this exists
  // The final job as a job of several tasks (issue 70: data-parallel
  // training), each running final_command through srun with its rank in
  // SLURM_PROCID; 1: one task, run directly. final_nodes > 0 spreads them
  // over that many nodes (sbatch --nodes); 0: where Slurm puts them.
  int final_tasks = 1;
  int final_nodes = 0;
  SlurmResources resources;
};

// Shell-quotes one argument ('...').
std::string ShellQuote(const std::string& argument);

// The job's scripts, written into its folder (made if missing).
void WriteJobScripts(const ArrayJob& job);

// Task indices not done yet (see ArrayJob::task_output).
std::vector<int> TasksToDo(const ArrayJob& job);

struct Submission {
  std::string array_job_id;  // empty when no task was submitted
  std::string final_job_id;  // empty when there is no final command or it is done
  std::vector<int> tasks;
};

// Writes the scripts, then submits the tasks not done as one array job and
// the final job after it (sbatch --parsable; --dependency=afterok). Appends
// the submission to jobs.json. Throws InputError when sbatch is missing or
// fails, or a task to submit is still queued or running.
Submission SubmitArrayJob(const ArrayJob& job);

// The sbatch commands a user would run by hand (--emit-only), after writing
// the scripts.
std::vector<std::string> EmitArrayJob(const ArrayJob& job);

// scancel for every array and final job the folder's submissions made
// (those already ended are left as they are); returns their ids. A rerun of
// the command resubmits what was not done.
std::vector<std::string> CancelJobs(const std::string& dir);

// State of every task and of the final job, from the job folder and squeue.
struct TaskState {
  int task = -1;      // -1: the final job
  std::string state;  // done, failed (exit N), queued, running, missing
};
struct JobFolderState {
  std::string name;
  std::vector<TaskState> tasks;  // the final job last
  bool finished = false;         // every task and the final job done
  bool failed = false;           // something failed or is missing and nothing is queued
};
JobFolderState ReadJobFolder(const std::string& dir);

}  // namespace furn
