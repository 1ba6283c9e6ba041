// Issue 31 on a one-node Slurm cluster started by tools/slurm_local.sh (label
// `cluster`; needs root and the slurm-wlm and munge packages, else skipped):
// a 4-shard generate as an array job equals the one-process run row for row,
// a 4-shard evaluate stores the one-process run, a cancelled task is
// resubmitted alone by a rerun, protocol E's folds and tune's trials as tasks
// give the one-process metrics.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include "core/learned/vote_net.h"
#include "core/model/trained_model.h"
#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "tests/test_util.h"
#include "tests/workbench/dataset_dump.h"
#include "tests/workbench/heat_difference.h"
#include "tests/workbench/workbench_commands.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn {
namespace {

testing::CommandResult Shell(const std::string& command) { return testing::RunCommand(command); }

class Cluster : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (geteuid() != 0 || Shell("command -v slurmctld").exit_code != 0) return;
    dir_ = new std::string(testing::ScratchDir());
    const testing::CommandResult start =
        Shell("bash " FURN_SOURCE_DIR "/tools/slurm_local.sh start " + *dir_ + "/slurm");
    if (start.exit_code != 0) {
      std::fprintf(stderr, "cluster did not start: %s\n", start.output.c_str());
      return;
    }
    setenv("SLURM_CONF", (*dir_ + "/slurm/slurm.conf").c_str(), 1);
    started_ = true;
  }
  static void TearDownTestSuite() {
    if (dir_ != nullptr)
      Shell("bash " FURN_SOURCE_DIR "/tools/slurm_local.sh stop " + *dir_ + "/slurm");
  }
  void SetUp() override {
    if (geteuid() != 0 || Shell("command -v slurmctld").exit_code != 0)
      GTEST_SKIP() << "needs root and slurm-wlm (bash tools/install_deps.sh)";
    ASSERT_TRUE(started_) << "tools/slurm_local.sh start failed";
  }
  static testing::CommandResult Workbench(const std::string& arguments) {
    return Shell(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
  }
  static inline std::string* dir_ = nullptr;
  static inline bool started_ = false;
};

constexpr const char* kGenerate =
    "generate --catalog procedural:4 --rooms 8 --frames 2 --seed 5 --quiet";

// kGenerate as a 4-task array job with its folder in `dir`, merged into dir/merged.db.
std::string ShardedGenerate(const std::string& dir) {
  return std::string(kGenerate) + " --out " + dir +
         "/merged.db --shards 4 --cpus 1 --slurm --job-dir " + dir + "/job";
}

// Jobs submitted while the partition is down stay queued, so that a test can
// act on them before they run (sbatch reads no environment variable for
// --hold, and the workbench offers none).
testing::CommandResult SetPartition(const std::string& state) {
  return Shell("scontrol update PartitionName=local State=" + state);
}

std::string WaitFor(const std::string& dir, int timeout_s) {
  return "jobs wait " + dir + "/job --poll 0.5 --timeout " + std::to_string(timeout_s) + " --quiet";
}

TEST_F(Cluster, FourShardGenerateEqualsOneProcess) {
  const std::string dir = testing::ScratchDir();
  ASSERT_EQ(Workbench(std::string(kGenerate) + " --out " + dir + "/one.db").exit_code, 0);
  const testing::CommandResult submit = Workbench(ShardedGenerate(dir));
  ASSERT_EQ(submit.exit_code, 0) << submit.output;
  EXPECT_NE(submit.output.find("4 of 4 tasks"), std::string::npos) << submit.output;
  const testing::CommandResult wait = Workbench(WaitFor(dir, 300));
  ASSERT_EQ(wait.exit_code, 0) << wait.output;
  EXPECT_EQ(testing::DumpDataset(dir + "/merged.db"), testing::DumpDataset(dir + "/one.db"));
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/job/status/task-" + std::to_string(k) + ".ok"));
    EXPECT_TRUE(std::filesystem::exists(dir + "/job/logs/task-" + std::to_string(k) + ".log"));
  }
  // Everything done: a rerun submits nothing.
  const testing::CommandResult again = Workbench(ShardedGenerate(dir));
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("nothing submitted"), std::string::npos) << again.output;

  // A 4-shard evaluate of the merged dataset stores the run one process
  // stores on its twin (timings aside).
  const std::string model = dir + "/m.fcm";
  ASSERT_EQ(Workbench(std::string(testing::kTrainSmallCodebook) + model).exit_code, 0);
  const std::string evaluate = "evaluate --quiet --split all --model " + model + " --db ";
  ASSERT_EQ(Workbench(evaluate + dir + "/one.db").exit_code, 0);
  const testing::CommandResult sharded = Workbench(
      evaluate + dir + "/merged.db --shards 4 --cpus 1 --slurm --job-dir " + dir + "/eval");
  ASSERT_EQ(sharded.exit_code, 0) << sharded.output;
  EXPECT_NE(sharded.output.find("4 of 4 tasks"), std::string::npos) << sharded.output;
  const testing::CommandResult waited =
      Workbench("jobs wait " + dir + "/eval --poll 0.5 --timeout 300 --quiet");
  ASSERT_EQ(waited.exit_code, 0) << waited.output;
  const std::string runs = testing::DumpRuns(dir + "/one.db");
  EXPECT_GT(runs.size(), 1000u);
  EXPECT_EQ(testing::DumpRuns(dir + "/merged.db"), runs);
}

// Tune with a task per trial (detector options only: no training), the
// final job ranking them: the one-process search's runs and best options.
TEST_F(Cluster, TuneTrialTasksGiveTheOneProcessSearch) {
  const std::string dir = testing::ScratchDir();
  ASSERT_EQ(Workbench(std::string(kGenerate) + " --out " + dir + "/one.db").exit_code, 0);
  std::filesystem::copy_file(dir + "/one.db", dir + "/array.db");
  testing::WriteText(dir + "/base.json",
                     R"({"trainer": {"scan": {"azimuths": 8},
                                     "vocabulary": {"kind": "kmeans", "words": 20}}})");
  ASSERT_EQ(Workbench("train --no-vote-net --catalog procedural:4 --quiet --options " + dir +
                      "/base.json --out " + dir + "/m.fcm")
                .exit_code,
            0);
  testing::WriteText(dir + "/space.json", R"({"detector.relative_threshold": [0.15, 0.4, 0.6]})");
  auto tune = [&](const std::string& name) {
    return "tune --catalog procedural:4 --quiet --strategy grid --trials 3 --model " + dir +
           "/m.fcm --options " + dir + "/base.json --space " + dir + "/space.json --db " + dir +
           "/" + name + ".db --work-dir " + dir + "/work --out " + dir + "/report-" + name;
  };
  ASSERT_EQ(Workbench(tune("one")).exit_code, 0);
  const testing::CommandResult submit =
      Workbench(tune("array") + " --shards 3 --cpus 1 --slurm --job-dir " + dir + "/job");
  ASSERT_EQ(submit.exit_code, 0) << submit.output;
  EXPECT_NE(submit.output.find("3 of 3 tasks"), std::string::npos) << submit.output;
  const testing::CommandResult wait = Workbench(WaitFor(dir, 300));
  ASSERT_EQ(wait.exit_code, 0) << wait.output;
  EXPECT_EQ(testing::DumpRuns(dir + "/array.db"), testing::DumpRuns(dir + "/one.db"));
  EXPECT_EQ(ReadFileBytes(dir + "/report-array/best_options.json"),
            ReadFileBytes(dir + "/report-one/best_options.json"));
}

TEST_F(Cluster, ACancelledTaskIsResubmittedAloneByARerun) {
  const std::string dir = testing::ScratchDir();
  ASSERT_EQ(Workbench(std::string(kGenerate) + " --out " + dir + "/one.db").exit_code, 0);
  const std::string command = ShardedGenerate(dir);
  // Queued on a down partition, so that task 2 can be cancelled before it runs.
  ASSERT_EQ(SetPartition("DOWN").exit_code, 0);
  const testing::CommandResult submit = Workbench(command);
  const testing::CommandResult cancel = [&] {
    const std::string array = submit.output.substr(submit.output.find("array job ") + 10);
    return Shell("scancel " + array.substr(0, array.find(':')) + "_2");
  }();
  ASSERT_EQ(SetPartition("UP").exit_code, 0);
  ASSERT_EQ(submit.exit_code, 0) << submit.output;
  ASSERT_EQ(cancel.exit_code, 0) << cancel.output;
  const testing::CommandResult failed = Workbench(WaitFor(dir, 300));
  EXPECT_EQ(failed.exit_code, 1) << failed.output;
  EXPECT_NE(failed.output.find("task 2 missing"), std::string::npos) << failed.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/merged.db"));

  const testing::CommandResult rerun = Workbench(command);
  ASSERT_EQ(rerun.exit_code, 0) << rerun.output;
  EXPECT_NE(rerun.output.find("1 of 4 tasks"), std::string::npos) << rerun.output;
  const testing::CommandResult wait = Workbench(WaitFor(dir, 300));
  ASSERT_EQ(wait.exit_code, 0) << wait.output;
  EXPECT_EQ(testing::DumpDataset(dir + "/merged.db"), testing::DumpDataset(dir + "/one.db"));
}

// Protocol E with a task per fold (each trains its fold's model into the
// shared work directory) and the final crossval: the same metrics as one
// process (timings aside).
TEST_F(Cluster, CrossvalFoldTasksGiveTheOneProcessMetrics) {
  const std::string dir = testing::ScratchDir();
  ASSERT_EQ(Workbench("generate --catalog procedural:4 --rooms 9 --frames 2 --seed 5 "
                      "--model-folds 3 --quiet --out " +
                      dir + "/one.db")
                .exit_code,
            0);
  std::filesystem::copy_file(dir + "/one.db", dir + "/array.db");
  ASSERT_EQ(
      Workbench("crossval --no-vote-net --quiet --db " + dir + "/one.db --work-dir " + dir + "/m1")
          .exit_code,
      0);
  const testing::CommandResult submit =
      Workbench("crossval --no-vote-net --quiet --db " + dir + "/array.db --work-dir " + dir +
                "/m2 --shards 3 --cpus 1 --slurm --job-dir " + dir + "/job");
  ASSERT_EQ(submit.exit_code, 0) << submit.output;
  const testing::CommandResult wait = Workbench(WaitFor(dir, 500));
  ASSERT_EQ(wait.exit_code, 0) << wait.output;
  auto metrics = [](const std::string& db) {
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    std::map<std::string, double> kept;
    for (const auto& [name, value] : dataset.RunMetrics(dataset.Runs().back().id)) {
      if (name.find("latency") == std::string::npos && name.find("_ms") == std::string::npos)
        kept[name] = value;
    }
    return kept;
  };
  const std::map<std::string, double> one = metrics(dir + "/one.db");
  EXPECT_GT(one.size(), 20u);
  EXPECT_EQ(metrics(dir + "/array.db"), one);
  const testing::CommandResult bad =
      Workbench("crossval --no-vote-net --quiet --db " + dir + "/array.db --work-dir " + dir +
                "/m3 --shards 4 --slurm --job-dir " + dir + "/job4");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.output.find("has 3 folds"), std::string::npos) << bad.output;
}

// Issue 70: `train --vote-workers 2 --slurm` trains the network as one job
// of two tasks (srun; c10d over Gloo, met through a store in the job
// folder) after one task made the rooms; the model is one process's within
// the tolerance data-parallel training states (docs/training.md), and the
// same bytes as two local processes (`--vote-workers 2` without --slurm).
TEST_F(Cluster, TwoSlurmTasksTrainOneProcesssModel) {
  const std::string dir = testing::ScratchDir();
  const std::string train =
      "train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 6 --vote-rooms 6 "
      "--vote-frames 2 --vote-epochs 2 --vote-threads 1 --quiet --out ";
  ASSERT_EQ(Workbench(train + dir + "/one.fcm --keep-rooms").exit_code, 0);
  const testing::CommandResult submit = Workbench(
      train + dir + "/two.fcm --vote-workers 2 --cpus 1 --slurm --job-dir " + dir + "/job");
  ASSERT_EQ(submit.exit_code, 0) << submit.output;
  const std::string script = ReadFileBytes(dir + "/job/final.sbatch");
  EXPECT_NE(script.find("#SBATCH --ntasks=2"), std::string::npos) << script;
  EXPECT_NE(script.find("srun --kill-on-bad-exit=1 "), std::string::npos) << script;
  const testing::CommandResult wait = Workbench(WaitFor(dir, 500));
  ASSERT_EQ(wait.exit_code, 0) << wait.output << ReadFileBytes(dir + "/job/logs/final.log");
  const VoteNet one = VoteNet::Deserialize(LoadTrainedModel(dir + "/one.fcm").vote_net, "one");
  const VoteNet two = VoteNet::Deserialize(LoadTrainedModel(dir + "/two.fcm").vote_net, "two");
  VoteNetTrainingOptions read;
  read.net = one.options();
  std::vector<BevSample> frames;
  ReadBevSamples(dir + "/one.fcm.rooms.db", read, &frames, nullptr);
  const double gap = testing::LargestHeatDifference(one, two, frames);
  std::printf("2 Slurm tasks against one process: largest heat difference %.4f\n", gap);
  EXPECT_GT(gap, 0.0) << "the same bytes: did the second task train at all?";
  EXPECT_LT(gap, 0.05);
  ASSERT_EQ(Workbench(train + dir + "/local.fcm --vote-workers 2").exit_code, 0);
  EXPECT_TRUE(ReadFileBytes(dir + "/local.fcm") == ReadFileBytes(dir + "/two.fcm"))
      << "two Slurm tasks and two local processes trained different networks";
  const std::string log = ReadFileBytes(dir + "/job/logs/final.log");
  EXPECT_EQ(log.find("error"), std::string::npos) << log;
  // Not a Slurm task, or a job of another size: one line naming the rule.
  const testing::CommandResult outside =
      Shell("env -u SLURM_PROCID " + std::string(FURN_WORKBENCH_BINARY) + " " + train + dir +
            "/x.fcm --vote-workers 2 --vote-slurm-group " + dir + "/g 2>&1");
  EXPECT_EQ(outside.exit_code, 1);
  EXPECT_NE(outside.output.find("runs in a task of a Slurm job"), std::string::npos)
      << outside.output;
  const testing::CommandResult nodes =
      Workbench(train + dir + "/y.fcm --vote-workers 2 --nodes 3 --slurm --job-dir " + dir + "/j3");
  EXPECT_EQ(nodes.exit_code, 1);
  EXPECT_NE(nodes.output.find("--nodes 3 must be in 0..2"), std::string::npos) << nodes.output;
}

// `jobs cancel` ends every job of the folder; the job then reads as failed
// (nothing queued, tasks missing), and a rerun would resubmit them all.
TEST_F(Cluster, JobsCancelEndsTheTasksAndTheFinalJob) {
  const std::string dir = testing::ScratchDir();
  ASSERT_EQ(SetPartition("DOWN").exit_code, 0);  // nothing runs before the cancel
  const testing::CommandResult submit = Workbench(ShardedGenerate(dir));
  const testing::CommandResult cancel = Workbench("jobs cancel " + dir + "/job");
  ASSERT_EQ(SetPartition("UP").exit_code, 0);
  ASSERT_EQ(submit.exit_code, 0) << submit.output;
  ASSERT_EQ(cancel.exit_code, 0) << cancel.output;
  EXPECT_NE(cancel.output.find("cancelled jobs "), std::string::npos) << cancel.output;
  std::string queued = "?";
  for (int k = 0; k < 40 && !queued.empty(); ++k) {  // scancel returns before the queue empties
    queued = Shell("squeue -h -o %i").output;
    if (!queued.empty()) usleep(250000);
  }
  EXPECT_EQ(queued, "");
  const testing::CommandResult status = Workbench("jobs status " + dir + "/job");
  EXPECT_EQ(status.exit_code, 1) << status.output;
  EXPECT_NE(status.output.find("task 3   missing"), std::string::npos) << status.output;
}

TEST_F(Cluster, BadFlagsAreOneLine) {
  const std::string dir = testing::ScratchDir();
  for (const std::string& flags :
       {std::string("--shards 4 --job-dir ") + dir + "/j",
        std::string("--shards 4 --slurm"),
        std::string("--slurm"),
        std::string("--shards 4 --slurm --emit-only --job-dir ") + dir}) {
    const testing::CommandResult bad =
        Workbench(std::string(kGenerate) + " --out " + dir + "/x.db " + flags);
    EXPECT_EQ(bad.exit_code, 1) << flags << ": " << bad.output;
    EXPECT_EQ(bad.output.find('\n'), bad.output.size() - 1) << bad.output;
  }
  const testing::CommandResult emit =
      Workbench(std::string(kGenerate) + " --out " + dir +
                "/e.db --shards 3 --emit-only --job-dir " + dir + "/emit");
  ASSERT_EQ(emit.exit_code, 0) << emit.output;
  EXPECT_NE(emit.output.find("--array=0,1,2"), std::string::npos) << emit.output;
  EXPECT_NE(emit.output.find("--dependency=afterok:$array"), std::string::npos) << emit.output;
  EXPECT_TRUE(std::filesystem::exists(dir + "/emit/task.sbatch"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/e.db"));
  const testing::CommandResult not_a_job = Workbench("jobs status " + dir);
  EXPECT_EQ(not_a_job.exit_code, 1);
  EXPECT_NE(not_a_job.output.find("not a job folder"), std::string::npos) << not_a_job.output;
}

}  // namespace
}  // namespace furn
