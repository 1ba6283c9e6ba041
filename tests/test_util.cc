#include "tests/test_util.h"

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "core/util/error.h"

namespace furn::testing {

namespace {

std::string ScratchDirFor(const std::string& base) {
  std::string name = base;
  // The same test run under a forced Embree or torch ISA (furn_add_test's
  // EMBREE_ISAS, TORCH_ISAS) runs alongside the plain one: it gets a folder
  // of its own (a shared one was seen to fail the torch-avx2 run).
  for (const char* variable : {"FURN_EMBREE_CONFIG", "FURN_TORCH_ISA"}) {
    const char* config = std::getenv(variable);
    if (config == nullptr || *config == 0) continue;
    name += "@";
    for (const char* c = config; *c; ++c) {
      const bool plain = std::isalnum(static_cast<unsigned char>(*c)) || *c == '.';
      name += plain ? *c : '_';
    }
  }
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "furn_tests" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

}  // namespace

std::string ScratchDir() {
  const ::testing::UnitTest* unit = ::testing::UnitTest::GetInstance();
  if (const ::testing::TestInfo* info = unit->current_test_info()) {
    return ScratchDirFor(std::string(info->test_suite_name()) + "." + info->name());
  }
  // A suite's SetUpTestSuite: one folder for the suite (register it WHOLE,
  // so no two processes share it).
  return ScratchDirFor(std::string(unit->current_test_suite()->name()) + ".suite");
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

std::string ErrorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const InputError& error) {
    return error.what();
  }
  return "(no error)";
}

CommandResult RunCommand(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  size_t got;
  while ((got = fread(buffer.data(), 1, buffer.size(), pipe)) > 0)
    result.output.append(buffer.data(), got);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::string StartInBackground(const std::string& command, const std::string& log) {
  const CommandResult started = RunCommand(command + " > " + log + " 2>&1 & echo $!");
  return started.output.substr(0, started.output.find('\n'));
}

bool WaitUntil(const std::function<bool()>& done, double timeout_s, int poll_ms) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
  }
  return true;
}

void KillHard(const std::string& pid) {
  RunCommand("kill -9 " + pid);
  WaitUntil([&] { return RunCommand("kill -0 " + pid).exit_code != 0; }, 10, 50);
}

std::string SceneSelfTest(const std::string& page, std::string* output) {
  const CommandResult browser = RunCommand(
      "chromium --headless --no-sandbox --disable-gpu --window-size=1200,800 "
      "--virtual-time-budget=10000 --dump-dom 'file://" +
      std::filesystem::absolute(page).string() + "#selftest' 2>/dev/null");
  if (output != nullptr) *output = browser.output;
  const std::string open = "<pre id=\"scene-check\">";
  const size_t at = browser.output.find(open);
  if (at == std::string::npos) return "";
  const size_t end = browser.output.find("</pre>", at);
  std::string text = browser.output.substr(at + open.size(), end - at - open.size());
  for (const auto& [entity, character] :  // --dump-dom escapes these in text
       {std::pair<std::string, std::string>{"&quot;", "\""},
        {"&lt;", "<"},
        {"&gt;", ">"},
        {"&amp;", "&"}}) {
    for (size_t k = text.find(entity); k != std::string::npos; k = text.find(entity, k + 1))
      text.replace(k, entity.size(), character);
  }
  return text;
}

}  // namespace furn::testing
