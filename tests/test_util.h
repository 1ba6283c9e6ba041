// Helpers for tests: a fresh scratch directory per test, and writing files.
#pragma once

#include <functional>
#include <string>

namespace furn::testing {

// A new empty directory under the build tree, named after the running test
// (or suite, from SetUpTestSuite).
std::string ScratchDir();

void WriteText(const std::string& path, const std::string& text);

// The message of the InputError `action` throws, or "(no error)".
std::string ErrorOf(const std::function<void()>& action);

// Runs a shell command; stdout and stderr together, and the exit code (-1
// when it did not exit normally).
struct CommandResult {
  int exit_code = -1;
  std::string output;
};
CommandResult RunCommand(const std::string& command);

// Starts a shell command in the background (its output to `log`) and
// returns its process id.
std::string StartInBackground(const std::string& command, const std::string& log);
// Waits (polling every `poll_ms`, at most `timeout_s`) until `done` holds;
// returns whether it did.
bool WaitUntil(const std::function<bool()>& done, double timeout_s, int poll_ms = 20);
// SIGKILL to the process, then waits until it is gone: what a power cut or
// the OOM killer does to a run.
void KillHard(const std::string& pid);

// Opens a 3-D scene page (reports/scene_view.h) in headless Chromium with
// #selftest and returns what the page wrote into <pre id="scene-check"> (a
// JSON object: counts, toggles, drawn pixels, load_ms, errors), or "" with
// the browser's output in *output when it wrote nothing.
std::string SceneSelfTest(const std::string& page, std::string* output = nullptr);

}  // namespace furn::testing
