#include "workbench/pipelines/slurm_jobs.h"

#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "workbench/formats/json_text.h"
#include "workbench/pipelines/run_program.h"

namespace furn {
namespace {

namespace fs = std::filesystem;

std::string JobsJson(const std::string& dir) { return dir + "/jobs.json"; }
std::string StatusFile(const std::string& dir, const std::string& who, const char* suffix) {
  return dir + "/status/" + who + suffix;
}
std::string TaskName(int task) { return "task-" + std::to_string(task); }

std::string ReplaceTask(const std::string& text, int task) {
  std::string out = text;
  for (size_t at = out.find("$TASK"); at != std::string::npos; at = out.find("$TASK", at))
    out.replace(at, 5, std::to_string(task));
  return out;
}

std::pair<std::string, int> Capture(const std::vector<std::string>& argv) {
  ProgramResult result = RunProgram(argv);
  return {std::move(result.output), result.exit_code};
}

// A Slurm job id as jobs.json may hold it: digits, or digits_digits (an
// array task).
bool IsJobId(const std::string& id) {
  if (id.empty() || id.size() > 24) return false;
  const size_t underscore = id.find('_');
  const std::string head = id.substr(0, underscore);
  const std::string tail = underscore == std::string::npos ? "0" : id.substr(underscore + 1);
  auto digits = [](const std::string& text) {
    return !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
  };
  return digits(head) && digits(tail);
}

// Refuses control characters (a newline ends an #SBATCH comment and starts
// a command) in a text that lands in a script.
void RequirePrintable(const std::string& text, const std::string& what) {
  for (char c : text) {
    Require(static_cast<unsigned char>(c) >= 0x20 && c != 0x7f,
            what +
                " must not hold control characters (line breaks, tabs, escapes): it is "
                "written into a job script");
  }
}

// The first bytes of a small status file (a task's exit code): a file grown
// huge is never read whole.
std::string ReadStatusFile(const std::string& path) {
  RequireRegularFile(path);
  std::ifstream in(path, std::ios::binary);
  std::string head(64, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  return head;
}

std::string Trim(std::string text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  return text;
}

// The script header: name, log, resources.
std::string Header(const ArrayJob& job, const std::string& what, const std::string& log) {
  std::ostringstream s;
  s << "#!/bin/bash\n# Written by workbench (issue 31): " << what << " of '" << job.name
    << "'; submit with sbatch, or rerun the workbench command.\n";
  s << "#SBATCH --job-name=" << ShellQuote("furn-" + job.name) << "\n";
  s << "#SBATCH --output=" << ShellQuote(log) << "\n";
  s << "#SBATCH --cpus-per-task=" << job.resources.cpus << "\n";
  if (!job.resources.partition.empty())
    s << "#SBATCH --partition=" << ShellQuote(job.resources.partition) << "\n";
  if (!job.resources.time.empty()) s << "#SBATCH --time=" << ShellQuote(job.resources.time) << "\n";
  if (!job.resources.mem.empty()) s << "#SBATCH --mem=" << ShellQuote(job.resources.mem) << "\n";
  return s.str();
}

// The final job's tasks and nodes, when it has more than one task.
std::string FinalTasks(const ArrayJob& job) {
  if (job.final_tasks == 1) return "";
  std::string lines = "#SBATCH --ntasks=" + std::to_string(job.final_tasks) + "\n";
  if (job.final_nodes > 0) lines += "#SBATCH --nodes=" + std::to_string(job.final_nodes) + "\n";
  return lines;
}

// The final command, through srun when the job has several tasks (a task
// that fails ends the others: --kill-on-bad-exit).
std::string FinalCommand(const ArrayJob& job) {
  if (job.final_tasks == 1) return job.final_command;
  return "srun --kill-on-bad-exit=1 " + job.final_command;
}

// Runs `command` in the folder the workbench command was given in (its
// relative paths mean what they meant there) and records its exit status as
// STATUS.ok or STATUS.failed.
std::string Body(const std::string& status, const std::string& command) {
  std::ostringstream s;
  s << "set -u\n"
    << "cd " << ShellQuote(fs::current_path().string()) << " || exit 1\n"
    << "status=" << status << "\n"
    << "rm -f \"$status.ok\" \"$status.failed\"\n"
    << command << "\n"
    << "code=$?\n"
    << "if [ \"$code\" -eq 0 ]; then touch \"$status.ok\"; else echo \"$code\" > "
       "\"$status.failed\"; fi\n"
    << "exit \"$code\"\n";
  return s.str();
}

constexpr uintmax_t kMaxJobsJsonBytes = 16u << 20;
constexpr int kMaxTasks = 100000;

// jobs.json, read as data written by anyone: size, nesting, every field's
// type and range, and every job id checked before anything uses them.
nlohmann::json ReadJobs(const std::string& dir) {
  const std::string path = JobsJson(dir);
  Require(fs::exists(path), dir + ": not a job folder (no jobs.json)");
  RequireRegularFile(path);
  Require(fs::file_size(path) <= kMaxJobsJsonBytes,
          path + ": larger than 16 MiB; not a jobs.json this workbench wrote");
  const nlohmann::json jobs = ParseUserJson<nlohmann::json>(ReadFileBytes(path), path);
  auto bad = [&](const std::string& field, const std::string& rule) {
    return InputError(path + ": '" + field + "' " + rule);
  };
  if (!jobs.is_object()) throw bad("(the whole file)", "must be a JSON object");
  for (const char* key : {"name", "task_command", "task_output", "final_command", "final_output"}) {
    if (jobs.contains(key) && !jobs[key].is_string()) throw bad(key, "must be a string");
  }
  if (!jobs.contains("tasks") || !jobs["tasks"].is_number_integer() || jobs["tasks"] < 1 ||
      jobs["tasks"] > kMaxTasks)
    throw bad("tasks", "must be an integer in 1.." + std::to_string(kMaxTasks));
  if (!jobs.contains("submissions") || !jobs["submissions"].is_array())
    throw bad("submissions", "must be an array");
  for (const nlohmann::json& submission : jobs["submissions"]) {
    if (!submission.is_object()) throw bad("submissions", "must hold objects");
    for (const char* key : {"array", "final"}) {
      if (!submission.contains(key)) continue;
      const nlohmann::json& id = submission[key];
      if (!id.is_string() || (!id.get<std::string>().empty() && !IsJobId(id.get<std::string>())))
        throw bad(std::string("submissions.") + key,
                  "must be a Slurm job id (digits, or digits_digits) or empty");
    }
    if (submission.contains("tasks")) {
      if (!submission["tasks"].is_array()) throw bad("submissions.tasks", "must be an array");
      for (const nlohmann::json& task : submission["tasks"]) {
        if (!task.is_number_integer() || task < 0 || task >= jobs["tasks"])
          throw bad("submissions.tasks", "must hold task indices below 'tasks'");
      }
    }
  }
  return jobs;
}

// The job ids under `key` ("array" or "final") of the folder's submissions,
// oldest first; a submission without one (no task, or no final job left to
// run) adds nothing.
std::vector<std::string> SubmittedIds(const nlohmann::json& jobs, const char* key) {
  std::vector<std::string> ids;
  for (const auto& s : jobs["submissions"]) {
    if (!s.value(key, "").empty()) ids.push_back(s.value(key, ""));
  }
  return ids;
}

// Array task index -> squeue state letter code (PD, R, CG, ...) of the jobs
// in `ids`; empty when squeue is missing.
std::map<std::string, std::string> QueueStates(const std::vector<std::string>& ids) {
  std::map<std::string, std::string> states;
  if (ids.empty()) return states;
  std::string list;
  for (const std::string& id : ids) list += (list.empty() ? "" : ",") + id;
  // %i: job id with the array task (123_4); -r: one line per array task.
  const auto [out, code] = Capture({"squeue", "-h", "-r", "-o", "%i %t", "-j", list});
  if (code != 0) return states;
  std::istringstream lines(out);
  std::string id, state;
  while (lines >> id >> state) states[id] = state;
  return states;
}

}  // namespace

void SlurmResources::Check() const {
  Require(cpus >= 1 && cpus <= 1024, "--cpus " + std::to_string(cpus) + " must be in 1..1024");
  for (const std::string* value : {&partition, &time, &mem}) {
    Require(value->find_first_of("\n\r'\"") == std::string::npos,
            "slurm resource '" + *value + "' must not hold quotes or line breaks");
  }
}

std::string ShellQuote(const std::string& argument) {
  std::string quoted = "'";
  for (char c : argument) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

void WriteJobScripts(const ArrayJob& job) {
  Require(job.tasks >= 1 && job.tasks <= kMaxTasks, "an array job needs 1..100000 tasks");
  Require(job.final_tasks >= 1 && job.final_tasks <= 1024,
          "the final job's tasks " + std::to_string(job.final_tasks) + " must be in 1..1024");
  Require(job.final_nodes >= 0 && job.final_nodes <= job.final_tasks,
          "--nodes " + std::to_string(job.final_nodes) + " must be in 0.." +
              std::to_string(job.final_tasks) + " (at most one node per task)");
  job.resources.Check();
  RequirePrintable(job.dir, "the job folder (--job-dir)");
  Require(job.dir.find('$') == std::string::npos,
          "the job folder '" + job.dir + "' must not hold '$' (task outputs name $TASK)");
  RequirePrintable(job.name, "the job name");
  RequirePrintable(fs::current_path().string(), "the current folder");
  constexpr size_t kMaxCommandBytes = 1u << 20;
  Require(
      job.task_command.size() <= kMaxCommandBytes && job.final_command.size() <= kMaxCommandBytes,
      "a job's command line would be longer than 1 MiB; use fewer --shards");
  for (const std::string* text :
       {&job.task_command, &job.final_command, &job.task_output, &job.final_output})
    RequirePrintable(*text, "a job's command or output path");
  // A folder holding another command's jobs is refused before anything in
  // it is written.
  nlohmann::json jobs = fs::exists(JobsJson(job.dir)) ? ReadJobs(job.dir) : nlohmann::json{};
  Require(!jobs.contains("task_command") || jobs["task_command"] == job.task_command,
          job.dir + ": holds the jobs of another command; use a new --job-dir");
  std::error_code ec;
  fs::create_directories(job.dir + "/logs", ec);
  fs::create_directories(job.dir + "/status", ec);
  Require(!ec && fs::is_directory(job.dir + "/status"),
          job.dir + ": cannot make the job folder (" + ec.message() + ")");
  const std::string dir = fs::absolute(job.dir).string();
  WriteFileAtomically(job.dir + "/task.sbatch",
                      Header(job, "one task per shard", dir + "/logs/task-%a.log") +
                          "TASK=\"$SLURM_ARRAY_TASK_ID\"\n" +
                          Body(ShellQuote(dir + "/status/task-") + "\"$TASK\"", job.task_command));
  if (!job.final_command.empty()) {
    WriteFileAtomically(job.dir + "/final.sbatch",
                        Header(job, "the final step", dir + "/logs/final.log") + FinalTasks(job) +
                            Body(ShellQuote(dir + "/status/final"), FinalCommand(job)));
  }
  jobs["name"] = job.name;
  jobs["tasks"] = job.tasks;
  jobs["task_command"] = job.task_command;
  jobs["task_output"] = job.task_output;
  jobs["final_command"] = job.final_command;
  jobs["final_output"] = job.final_output;
  if (!jobs.contains("submissions")) jobs["submissions"] = nlohmann::json::array();
  WriteFileAtomically(JobsJson(job.dir), jobs.dump(2) + "\n");
}

std::vector<int> TasksToDo(const ArrayJob& job) {
  std::vector<int> todo;
  for (int task = 0; task < job.tasks; ++task) {
    const bool ok = fs::exists(StatusFile(job.dir, TaskName(task), ".ok"));
    const bool output = job.task_output.empty() || fs::exists(ReplaceTask(job.task_output, task));
    if (!(ok && output)) todo.push_back(task);
  }
  return todo;
}

namespace {

std::string ArrayList(const std::vector<int>& tasks) {
  std::string list;
  for (int task : tasks) list += (list.empty() ? "" : ",") + std::to_string(task);
  return list;
}

std::string Sbatch(const std::vector<std::string>& arguments) {
  std::vector<std::string> argv = {"sbatch", "--parsable"};
  argv.insert(argv.end(), arguments.begin(), arguments.end());
  const auto [out, code] = Capture(argv);
  if (code == 127)
    throw InputError("sbatch not found: is this a Slurm login node? (or use --emit-only)");
  Require(code == 0, "sbatch " + arguments.back() + " failed: " + Trim(out));
  const std::string id = Trim(out).substr(0, Trim(out).find(';'));  // "id;cluster"
  Require(IsJobId(id), "sbatch gave no job id: " + Trim(out).substr(0, 200));
  return id;
}

// Refuses to submit a task that an earlier submission still has queued or running.
void CheckNotQueued(const std::string& dir, const std::vector<int>& todo) {
  const auto states = QueueStates(SubmittedIds(ReadJobs(dir), "array"));
  const std::set<int> wanted(todo.begin(), todo.end());
  for (const auto& [id, state] : states) {
    const size_t underscore = id.find('_');
    if (underscore == std::string::npos) continue;
    const std::string index = id.substr(underscore + 1);
    if (index.find_first_not_of("0123456789") != std::string::npos) continue;
    if (wanted.count(std::stoi(index))) {
      throw InputError(dir + ": task " + index + " is still " + state + " (job " + id +
                       "); wait for it ('workbench jobs wait') or scancel it");
    }
  }
}

// An earlier submission's final job still waits for tasks that failed:
// cancelled, a new one follows the new tasks.
void CancelStaleFinal(const std::string& dir) {
  const nlohmann::json jobs = ReadJobs(dir);
  if (jobs["submissions"].empty()) return;
  const std::string final_id = jobs["submissions"].back().value("final", "");
  if (!final_id.empty()) Capture({"scancel", final_id});
}

// No final step, or it succeeded and its output is there.
bool FinalDone(const ArrayJob& job) {
  return job.final_command.empty() || (fs::exists(StatusFile(job.dir, "final", ".ok")) &&
                                       (job.final_output.empty() || fs::exists(job.final_output)));
}

}  // namespace

Submission SubmitArrayJob(const ArrayJob& job) {
  WriteJobScripts(job);
  Submission submission;
  submission.tasks = TasksToDo(job);
  if (submission.tasks.empty() && FinalDone(job)) return submission;
  CheckNotQueued(job.dir, submission.tasks);
  CancelStaleFinal(job.dir);
  if (!submission.tasks.empty()) {
    submission.array_job_id =
        Sbatch({"--array=" + ArrayList(submission.tasks), job.dir + "/task.sbatch"});
  }
  if (!job.final_command.empty()) {
    std::vector<std::string> arguments;
    if (!submission.array_job_id.empty())
      arguments.push_back("--dependency=afterok:" + submission.array_job_id);
    arguments.push_back(job.dir + "/final.sbatch");
    submission.final_job_id = Sbatch(arguments);
  }
  nlohmann::json jobs = ReadJobs(job.dir);
  jobs["submissions"].push_back({{"array", submission.array_job_id},
                                 {"tasks", submission.tasks},
                                 {"final", submission.final_job_id}});
  WriteFileAtomically(JobsJson(job.dir), jobs.dump(2) + "\n");
  return submission;
}

std::vector<std::string> EmitArrayJob(const ArrayJob& job) {
  WriteJobScripts(job);
  const std::vector<int> todo = TasksToDo(job);
  std::vector<std::string> commands;
  if (!todo.empty()) {
    commands.push_back("array=$(sbatch --parsable --array=" + ArrayList(todo) + " " +
                       ShellQuote(job.dir + "/task.sbatch") + ")");
  }
  if (!job.final_command.empty() && (!todo.empty() || !FinalDone(job))) {
    commands.push_back("sbatch " + std::string(todo.empty() ? "" : "--dependency=afterok:$array ") +
                       ShellQuote(job.dir + "/final.sbatch"));
  }
  return commands;
}

std::vector<std::string> CancelJobs(const std::string& dir) {
  const nlohmann::json jobs = ReadJobs(dir);
  std::vector<std::string> ids = SubmittedIds(jobs, "array");
  for (const std::string& id : SubmittedIds(jobs, "final")) ids.push_back(id);
  if (ids.empty()) return ids;
  std::vector<std::string> argv = {"scancel"};
  argv.insert(argv.end(), ids.begin(), ids.end());
  const auto [out, code] = Capture(argv);
  if (code == 127) throw InputError("scancel not found: is this a Slurm login node?");
  if (code != 0) {
    // Ended jobs make scancel complain; a job still queued after it did not go.
    const auto still = QueueStates(ids);
    Require(still.empty(),
            "scancel failed (exit " + std::to_string(code) + "): " +
                Trim(out).substr(0, Trim(out).find('\n')) + "; " + std::to_string(still.size()) +
                " job(s) of " + dir + " are still queued or running");
  }
  return ids;
}

JobFolderState ReadJobFolder(const std::string& dir) {
  const nlohmann::json jobs = ReadJobs(dir);
  JobFolderState result;
  result.name = jobs.value("name", "");
  const int tasks = jobs.value("tasks", 0);
  const std::vector<std::string> ids = SubmittedIds(jobs, "array");
  const std::vector<std::string> finals = SubmittedIds(jobs, "final");
  const std::string last_final = finals.empty() ? "" : finals.back();
  std::vector<std::string> queried = ids;
  if (!last_final.empty()) queried.push_back(last_final);
  const auto queue = QueueStates(queried);
  // The newest submission's queue entry for a task, if any.
  auto queued = [&](const std::string& suffix_or_id, bool is_task) -> std::string {
    if (!is_task) {
      const auto it = queue.find(suffix_or_id);
      return it == queue.end() ? "" : it->second;
    }
    for (auto id = ids.rbegin(); id != ids.rend(); ++id) {
      const auto it = queue.find(*id + "_" + suffix_or_id);
      if (it != queue.end()) return it->second;
    }
    return "";
  };
  auto describe = [&](const std::string& who, const std::string& output, const std::string& q) {
    if (!q.empty()) return std::string(q == "PD" ? "queued" : "running");
    if (fs::exists(StatusFile(dir, who, ".ok")) && (output.empty() || fs::exists(output)))
      return std::string("done");
    const std::string failed = StatusFile(dir, who, ".failed");
    if (fs::exists(failed)) {
      const std::string code = Trim(ReadStatusFile(failed));
      const bool number = !code.empty() && code.size() <= 3 &&
                          code.find_first_not_of("0123456789") == std::string::npos;
      return "failed (exit " + (number ? code : std::string("?")) + ")";
    }
    return std::string("missing");
  };
  bool all_done = true, anything_queued = false, anything_bad = false;
  for (int task = 0; task < tasks; ++task) {
    const std::string q = queued(std::to_string(task), true);
    const std::string state =
        describe(TaskName(task), ReplaceTask(jobs.value("task_output", ""), task), q);
    result.tasks.push_back({task, state});
    all_done = all_done && state == "done";
    anything_queued = anything_queued || !q.empty();
    anything_bad = anything_bad || state.rfind("failed", 0) == 0 || state == "missing";
  }
  if (!jobs.value("final_command", "").empty()) {
    // A final job whose tasks failed waits forever (DependencyNeverSatisfied)
    // unless the cluster cancels it: it does not count as queued then.
    const std::string q =
        last_final.empty() || (anything_bad && !anything_queued) ? "" : queued(last_final, false);
    std::string state = describe("final", jobs.value("final_output", ""), q);
    if (state == "missing" && !anything_bad && !all_done) state = "waiting for the tasks";
    result.tasks.push_back({-1, state});
    all_done = all_done && state == "done";
    anything_queued = anything_queued || !q.empty();
    // Missing with its tasks done and nothing queued: it died without a
    // status (or was never submitted); waiting longer would wait forever.
    anything_bad = anything_bad || state.rfind("failed", 0) == 0 || state == "missing";
  }
  result.finished = all_done;
  result.failed = !all_done && !anything_queued && anything_bad;
  return result;
}

}  // namespace furn
