// The job layer's logic alone (no Slurm): shell quoting that any argument
// survives, and which tasks a rerun submits again.
#include "workbench/pipelines/slurm_jobs.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/util/file_util.h"
#include "tests/test_util.h"
#include "workbench/pipelines/run_program.h"

namespace furn {
namespace {

TEST(ShellQuote, EveryArgumentReachesTheProgramUnchanged) {
  for (const std::string& argument : {std::string("plain"),
                                      std::string(""),
                                      std::string("two words"),
                                      std::string("it's"),
                                      std::string("'''"),
                                      std::string("$HOME `id` $(id) ; rm -rf / && |"),
                                      std::string("back\\slash \"double\" *?[glob]"),
                                      std::string("new\nline\ttab")}) {
    const std::string quoted = ShellQuote(argument);
    // The shell is the reader the scripts are written for.
    const ProgramResult echo = RunProgram({"bash", "-c", "printf %s " + quoted}, false);
    ASSERT_EQ(echo.exit_code, 0) << quoted;
    EXPECT_EQ(echo.output, argument) << quoted;
  }
}

TEST(TasksToDo, ATaskIsDoneWithItsOkAndItsOutput) {
  const std::string dir = testing::ScratchDir();
  ArrayJob job;
  job.dir = dir + "/job";
  job.tasks = 4;
  job.task_output = dir + "/out-$TASK.db";
  EXPECT_EQ(TasksToDo(job), (std::vector<int>{0, 1, 2, 3}));  // no folder yet
  std::filesystem::create_directories(job.dir + "/status");
  WriteFileAtomically(job.dir + "/status/task-0.ok", "0\n");  // ok, output there
  WriteFileAtomically(dir + "/out-0.db", "x");
  WriteFileAtomically(job.dir + "/status/task-1.ok", "0\n");  // ok, output lost
  WriteFileAtomically(dir + "/out-2.db", "x");                // output, no ok (killed)
  WriteFileAtomically(job.dir + "/status/task-3.failed", "1\n");
  EXPECT_EQ(TasksToDo(job), (std::vector<int>{1, 2, 3}));
  job.task_output.clear();  // the .ok alone decides
  EXPECT_EQ(TasksToDo(job), (std::vector<int>{2, 3}));
}

}  // namespace
}  // namespace furn
