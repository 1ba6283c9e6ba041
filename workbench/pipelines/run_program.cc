#include "workbench/pipelines/run_program.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <csignal>

#include "core/util/error.h"

extern char** environ;

namespace furn {
namespace {

// What the child reads and where its output goes.
void SetChildFiles(posix_spawn_file_actions_t* actions, const int fds[2], bool with_stderr) {
  posix_spawn_file_actions_addopen(actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(actions, fds[1], 1);
  if (with_stderr)
    posix_spawn_file_actions_adddup2(actions, fds[1], 2);
  else
    posix_spawn_file_actions_addopen(actions, 2, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addclose(actions, fds[0]);
  posix_spawn_file_actions_addclose(actions, fds[1]);
}

std::string ReadAll(int fd) {
  std::string out;
  std::array<char, 4096> buffer;
  ssize_t n = 0;
  while ((n = read(fd, buffer.data(), buffer.size())) != 0) {
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) break;
    if (out.size() < kMaxCapture) out.append(buffer.data(), static_cast<size_t>(n));
  }
  return out;
}

}  // namespace

ProgramResult RunProgram(const std::vector<std::string>& argv, bool with_stderr) {
  Require(!argv.empty(), "RunProgram needs a program");
  int fds[2];
  Require(pipe2(fds, O_CLOEXEC) == 0, "cannot run " + argv.front() + ": no pipe");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  SetChildFiles(&actions, fds, with_stderr);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  ProgramResult result{ReadAll(fds[0]), 0};
  close(fds[0]);
  if (spawned != 0) return {"", 127};
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  return result;
}

namespace {

int Reap(pid_t pid) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

}  // namespace

RunningProgram::RunningProgram(const std::vector<std::string>& argv, const std::string& log_path) {
  Require(!argv.empty(), "RunningProgram needs a program");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(
      &actions, 1, log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  Require(spawned == 0, "cannot start " + argv.front() + " (log " + log_path + ")");
  pid_ = pid;
}

RunningProgram::~RunningProgram() { Stop(); }

void RunningProgram::Stop() {
  if (pid_ < 0) return;
  kill(pid_, SIGTERM);
  exit_code_ = Reap(pid_);
  pid_ = -1;
}

int RunningProgram::Wait() {
  if (pid_ >= 0) {
    exit_code_ = Reap(pid_);
    pid_ = -1;
  }
  return *exit_code_;
}

std::optional<int> RunningProgram::Poll() {
  if (pid_ < 0) return exit_code_;
  int status = 0;
  const pid_t done = waitpid(pid_, &status, WNOHANG);
  if (done != pid_) return std::nullopt;
  exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  pid_ = -1;
  return exit_code_;
}

ProgramWatch::ProgramWatch(std::vector<RunningProgram*> programs,
                           std::function<void(size_t)> failed,
                           double period_s)
    : programs_(std::move(programs)), failed_(std::move(failed)) {
  const auto period = std::chrono::milliseconds(static_cast<int64_t>(period_s * 1000));
  thread_ = std::thread([this, period] {
    while (!stop_) {
      for (size_t i = 0; i < programs_.size(); ++i) {
        const std::optional<int> code = programs_[i]->Poll();
        if (code && *code != 0) {
          failed_(i);
          return;
        }
      }
      std::this_thread::sleep_for(period);
    }
  });
}

ProgramWatch::~ProgramWatch() { Stop(); }

void ProgramWatch::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

}  // namespace furn
