// Issue 39: the job folders, shard files and model files people share are
// data. Every hostile sample (tests/data/crashers/jobs_models, and the
// model files of ../shared/crashers/jobs_models when that folder exists)
// ends in one line naming the file, exit 1, nothing executed, within 10 s.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "tests/test_util.h"
#include "tests/workbench/workbench_commands.h"

namespace furn {
namespace {

namespace fs = std::filesystem;

const std::string kSamples = FURN_SOURCE_DIR "/tests/data/crashers/jobs_models/";
const std::string kSharedSamples = FURN_SOURCE_DIR "/../shared/crashers/jobs_models/";

// What an injection would leave behind.
const std::vector<std::string> kMarkers = {"/tmp/pwned_status_array",
                                           "/tmp/pwned_status_final",
                                           "/tmp/pwned_submit_array",
                                           "/tmp/pwned_submit_final",
                                           "/tmp/pwned_jobdir"};

class HostileSharedFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const std::string& marker : kMarkers) fs::remove(marker);
    dir_ = testing::ScratchDir();
  }
  void TearDown() override {
    for (const std::string& marker : kMarkers)
      EXPECT_FALSE(fs::exists(marker)) << marker << ": an injected command ran";
  }

  // The workbench's one-line refusal: exit 1, a single line naming `name`,
  // within 10 s.
  static void ExpectOneLine(const std::string& arguments, const std::string& name) {
    const auto start = std::chrono::steady_clock::now();
    const testing::CommandResult result =
        testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(result.exit_code, 1) << arguments << ": " << result.output;
    EXPECT_EQ(result.output.find('\n'), result.output.size() - 1)
        << arguments << ": " << result.output;
    EXPECT_NE(result.output.find(name), std::string::npos) << arguments << ": " << result.output;
    EXPECT_EQ(result.output.find("PWNED"), std::string::npos) << result.output;
    EXPECT_LT(seconds, 10) << arguments;
  }

  // A job folder holding `jobs_json` as its jobs.json.
  std::string JobFolder(const std::string& name, const std::string& jobs_json) const {
    const std::string folder = dir_ + "/" + name;
    fs::create_directories(folder + "/status");
    WriteFileAtomically(folder + "/jobs.json", jobs_json);
    return folder;
  }

  std::string dir_;
};

TEST_F(HostileSharedFiles, JobsJsonNeverReachesAShellNorTheStack) {
  std::vector<std::pair<std::string, std::string>> samples;
  for (const char* file : {"inj_jobs_json_submission_ids.json",
                           "jobs_json_empty_object_ub.json",
                           "jobs_json_tasks_2e31.json",
                           "inj_jobs_json_resubmit.json"})
    samples.emplace_back(file, ReadFileBytes(kSamples + file));
  samples.emplace_back("deep", std::string(1000000, '[') + std::string(1000000, ']'));
  for (const auto& [name, text] : samples) {
    const std::string folder = JobFolder(name, text);
    for (const std::string command : {"jobs status ", "jobs cancel ", "jobs wait --timeout 5 "})
      ExpectOneLine(command + folder, "jobs.json");
    // A sharded command meeting the folder refuses before it writes a script.
    ExpectOneLine("generate --catalog procedural:4 --rooms 2 --frames 1 --quiet --out " + dir_ +
                      "/g.db --shards 2 --emit-only --job-dir " + folder,
                  "jobs.json");
    EXPECT_FALSE(fs::exists(folder + "/task.sbatch")) << name;
  }
}

TEST_F(HostileSharedFiles, JobFolderNamesNeverBreakOutOfTheScript) {
  for (const std::string& job_dir :
       {dir_ + "/sl/j1\n$(touch /tmp/pwned_jobdir)\n", dir_ + "/sl/$TASK/j2", dir_ + "/j3\r"}) {
    const testing::CommandResult result =
        testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) +
                            " generate --catalog procedural:4 --rooms 2 --frames 1 --quiet --out " +
                            dir_ + "/g.db --shards 2 --emit-only --job-dir '" + job_dir + "'");
    EXPECT_EQ(result.exit_code, 1) << result.output;
    EXPECT_TRUE(result.output.find("control characters") != std::string::npos ||
                result.output.find("must not hold '$'") != std::string::npos)
        << result.output;
  }
  EXPECT_FALSE(fs::exists(dir_ + "/sl"));
}

TEST_F(HostileSharedFiles, ShardFilesAreTypedAndBounded) {
  const std::string model = dir_ + "/m.fcm", db = dir_ + "/d.db";
  ASSERT_EQ(testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " +
                                testing::kTrainSmallCodebook + model)
                .exit_code,
            0);
  ASSERT_EQ(testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) +
                                " generate --catalog procedural:4 --rooms 2 --frames 1 --quiet "
                                "--out " +
                                db)
                .exit_code,
            0);
  std::vector<std::string> shards;
  for (const char* file : {"shard_position_2e32_accepted.json",
                           "shard_version_string_unclear.json",
                           "shard_all_nulls_sqlite_constraint.json"})
    shards.push_back(kSamples + file);
  const std::string deep = dir_ + "/deep_version.json";
  WriteFileAtomically(deep,
                      "{\"format\": \"furn-evaluate-shard\", \"version\": " +
                          std::string(1000000, '[') + std::string(1000000, ']') + "}");
  shards.push_back(deep);
  for (const std::string& shard : shards) {
    ExpectOneLine("evaluate --quiet --model " + model + " --db " + db +
                      " --split all --merge-shards " + shard,
                  fs::path(shard).filename().string());
  }
  EXPECT_TRUE(DatasetDb(db, DatasetDb::Mode::kReadOnly).Runs().empty())
      << "a refused merge stored a run";
}

// The model samples (6 MB each) when the shared folder is there.
TEST_F(HostileSharedFiles, ModelFilesNeverRunCode) {
  if (!fs::exists(kSharedSamples) || testing::RunCommand("command -v xz").exit_code != 0)
    GTEST_SKIP() << kSharedSamples << " or xz missing (vote_net_test builds the same defects)";
  for (const char* file : {"torchscript_setstate_print.fcm.xz",
                           "torchscript_setstate_hang.fcm.xz",
                           "tensor_huge_size_numel.fcm.xz",
                           "records_4_bytes.fcm.xz"}) {
    const std::string model = dir_ + "/" + fs::path(file).stem().string();
    ASSERT_EQ(
        testing::RunCommand("xz -dc '" + kSharedSamples + file + "' > '" + model + "'").exit_code,
        0);
    ExpectOneLine("model info " + model, fs::path(model).filename().string());
  }
}

}  // namespace
}  // namespace furn
