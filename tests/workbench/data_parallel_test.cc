// Data-parallel training of the vote network (issue 70): torch's c10d over
// Gloo joins the ranks; each rasterises and trains on its share of the rooms
// and every rank takes the same step; the network matches one process's
// within the tolerance batch normalisation leaves (each rank normalises its
// own part of a batch). Ranks here are threads of the test (the group is
// the same as between processes, through its store file) and, in the CLI
// test, processes `train --vote-workers 2` starts.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>

#include "core/learned/data_parallel.h"
#include "core/model/trained_model.h"
#include "core/util/error.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "tests/test_util.h"
#include "tests/workbench/heat_difference.h"
#include "workbench/pipelines/generate.h"
#include "workbench/pipelines/run_program.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn {
namespace {

TEST(DataParallel, AGroupOfTwoSumsWhatItsRanksHold) {
  const std::string store = testing::ScratchDir() + "/store";
  std::vector<double> sums[2];
  std::vector<float> floats[2];
  auto rank = [&](int r) {
    DataParallelOptions options;
    options.rank = r;
    options.world = 2;
    options.store_path = store;
    DataParallelGroup group(options);
    sums[r] = {1.0 + r, 10.0 * r};
    group.SumDoubles(&sums[r]);
    floats[r] = {0.5f, static_cast<float>(r)};
    group.SumFloats(floats[r].data(), floats[r].size());
  };
  std::thread zero(rank, 0), one(rank, 1);
  zero.join();
  one.join();
  for (int r = 0; r < 2; ++r) {
    EXPECT_EQ(sums[r], (std::vector<double>{3.0, 10.0}));
    EXPECT_EQ(floats[r], (std::vector<float>{1.0f, 1.0f}));
  }
  DataParallelOptions bad;
  bad.world = 2;
  bad.rank = 2;
  bad.store_path = store;
  EXPECT_NE(testing::ErrorOf([&] { bad.Check(); }).find("rank 2 must be in 0..1"),
            std::string::npos);
  bad.rank = 0;
  bad.store_path.clear();
  EXPECT_NE(testing::ErrorOf([&] { bad.Check(); }).find("needs a store file"), std::string::npos);
  DataParallelOptions alone;  // world 1: no group, sums are the values
  DataParallelGroup single(alone);
  std::vector<double> same{4.0};
  single.SumDoubles(&same);
  EXPECT_EQ(same[0], 4.0);
}

VoteNetTrainingOptions SmallTraining() {
  VoteNetTrainingOptions options;
  options.net.grid.rows = 32;
  options.net.grid.cols = 32;
  options.net.grid.cell_m = 0.1;
  options.net.width = 4;
  options.epochs = 3;
  options.batch_size = 4;
  options.threads = 1;
  options.validation_share = 0;
  options.quiet = true;
  return options;
}

// Two ranks on their halves of the rooms end with the same bytes, see every
// frame between them, and land near one process on all the rooms.
TEST(DataParallel, TwoRanksTrainOneNetworkNearOneProcesssOwn) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  GenerateOptions generate;
  generate.catalog_spec = "procedural:2";
  generate.rooms = 6;
  generate.room.frames_per_room = 2;
  const std::string db = dir + "/rooms.db";
  GenerateDataset(OpenCatalog("procedural:2"), generate, db);
  const VoteNetTrainingOptions options = SmallTraining();

  std::vector<BevSample> all;
  ReadBevSamples(db, options, &all, nullptr);
  VoteNetTrainingSummary single_summary;
  const VoteNet single = TrainVoteNetOnSamples(all, {}, options, &single_summary);

  std::string bytes[2];
  size_t held[2] = {0, 0};
  VoteNetTrainingSummary summaries[2];
  auto rank = [&](int r) {
    DataParallelOptions parallel;
    parallel.rank = r;
    parallel.world = 2;
    parallel.store_path = dir + "/store";
    DataParallelGroup group(parallel);
    SampleShare share{&group, 0, {}};
    std::vector<BevSample> mine;
    ReadBevSamples(db, options, &mine, nullptr, nullptr, &share);
    held[r] = mine.size();
    EXPECT_EQ(share.total, all.size());
    bytes[r] = TrainVoteNetOnSamples(mine, {}, options, &summaries[r], nullptr, &share).Serialize();
  };
  std::thread zero(rank, 0), one(rank, 1);
  zero.join();
  one.join();
  EXPECT_EQ(held[0] + held[1], all.size());
  EXPECT_GT(held[1], 0u);
  EXPECT_TRUE(bytes[0] == bytes[1]) << "the ranks took different steps";
  EXPECT_EQ(summaries[0].frames, single_summary.frames);
  EXPECT_EQ(summaries[0].objects, single_summary.objects);
  const VoteNet parallel = VoteNet::Deserialize(bytes[0], "rank 0");
  const double loss_gap =
      std::abs(summaries[0].epochs.back().train_loss - single_summary.epochs.back().train_loss) /
      single_summary.epochs.back().train_loss;
  const double heat_gap = testing::LargestHeatDifference(parallel, single, all);
  std::printf(
      "two ranks against one process: last epoch's loss %.4f vs %.4f (%.1f %%), largest "
      "heat difference %.4f\n",
      summaries[0].epochs.back().train_loss,
      single_summary.epochs.back().train_loss,
      100 * loss_gap,
      heat_gap);
  // Measured: 1.0 % and 0.005.
  EXPECT_LT(loss_gap, 0.05);
  EXPECT_LT(heat_gap, 0.05);
}

testing::CommandResult Workbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments + " 2>&1");
}

// `train --vote-workers 2`: rank 0 starts the other process itself; the
// model is one process's within the tolerance above, and neither the store
// nor the worker's log is left behind.
TEST(DataParallel, TrainWithTwoWorkerProcesses) {
  const std::string dir = testing::ScratchDir();
  const std::string train =
      "train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 6 --vote-rooms 6 "
      "--vote-frames 2 --vote-epochs 2 --vote-threads 1 --keep-rooms --quiet --out ";
  ASSERT_EQ(Workbench(train + dir + "/one.fcm").exit_code, 0);
  const testing::CommandResult two = Workbench(train + dir + "/two.fcm --vote-workers 2");
  ASSERT_EQ(two.exit_code, 0) << two.output;
  const VoteNet one = VoteNet::Deserialize(LoadTrainedModel(dir + "/one.fcm").vote_net, "one");
  const VoteNet both = VoteNet::Deserialize(LoadTrainedModel(dir + "/two.fcm").vote_net, "two");
  VoteNetTrainingOptions read;
  read.net = one.options();
  std::vector<BevSample> frames;
  ReadBevSamples(dir + "/one.fcm.rooms.db", read, &frames, nullptr);
  const double gap = testing::LargestHeatDifference(one, both, frames);
  std::printf("train --vote-workers 2 against one process: largest heat difference %.4f\n", gap);
  EXPECT_GT(gap, 0.0) << "the same bytes: did the workers train at all?";
  EXPECT_LT(gap, 0.05);
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    EXPECT_EQ(name.find(".group"), std::string::npos) << name;
    EXPECT_EQ(name.find(".worker-"), std::string::npos) << name;
  }
  const testing::CommandResult bad = Workbench(train + dir + "/bad.fcm --vote-workers 0");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.output.find("--vote-workers 0 must be in 1..64"), std::string::npos) << bad.output;
  const testing::CommandResult ensemble =
      Workbench(train + dir + "/bad.fcm --vote-workers 2 --vote-ensemble 2");
  EXPECT_NE(ensemble.output.find("not an ensemble"), std::string::npos) << ensemble.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.fcm"));
}

// What lets rank 0 stop at once when a worker dies: a program that fails is
// reported (once, by its index); one that succeeds is not; Poll and Wait
// agree on the exit code.
TEST(DataParallel, AWatchReportsTheWorkerThatFailed) {
  const std::string log = testing::ScratchDir() + "/programs.log";
  RunningProgram fine({"/bin/true"}, log), broken({"/bin/false"}, log);
  std::atomic<int> reported{-1}, calls{0};
  {
    ProgramWatch watch(
        {&fine, &broken},
        [&](size_t i) {
          reported = static_cast<int>(i);
          ++calls;
        },
        0.01);
    for (int i = 0; i < 500 && calls == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(reported, 1);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(broken.Poll(), std::optional<int>(1));
  EXPECT_EQ(broken.Wait(), 1);
  EXPECT_EQ(fine.Wait(), 0);
  RunningProgram running({"/bin/sleep", "30"}, log);
  EXPECT_FALSE(running.Poll().has_value());
  running.Stop();
  EXPECT_EQ(running.Wait(), 128) << "stopped by a signal";
}

}  // namespace
}  // namespace furn
