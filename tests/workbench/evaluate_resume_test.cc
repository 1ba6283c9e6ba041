// Issue 72: a killed evaluation resumes (apart from evaluate_test, whose
// tests run again with Embree forced to AVX2: resuming has nothing of the
// ray caster's to check twice).
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "db/sqlite.h"
#include "tests/test_util.h"
#include "tests/workbench/workbench_commands.h"

namespace furn {
namespace {

testing::CommandResult Workbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
}

// Issue 72: an evaluation killed (SIGKILL) part-way and run again detects
// only the frames it had not saved (`<db>.evaluate-<key>.partial`) and
// stores one run equal to an uninterrupted one's: the same metrics and the
// same detections; the progress file is gone once the run is stored.
TEST(Evaluate, AKilledEvaluationResumesToTheSameRun) {
  const std::string dir = testing::ScratchDir();
  const std::string db = dir + "/d.db", again = dir + "/again.db", model = dir + "/m.fcm";
  ASSERT_EQ(
      Workbench("generate --catalog procedural:4 --rooms 8 --frames 2 --seed 5 --quiet --out " + db)
          .exit_code,
      0);
  ASSERT_EQ(Workbench(std::string(testing::kTrainSmallCodebook) + model).exit_code, 0);
  std::filesystem::copy_file(db, again);
  const std::string evaluate = " evaluate --split all --model " + model + " --db ";
  ASSERT_EQ(Workbench(evaluate + db + " --quiet").exit_code, 0);

  const std::string log = dir + "/killed.log";
  const std::string pid = testing::StartInBackground(
      "FURN_EVALUATE_SAVE_SECONDS=0 " + std::string(FURN_WORKBENCH_BINARY) + evaluate + again, log);
  auto partial = [&]() -> std::string {
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("again.db.evaluate-", 0) == 0 && entry.path().extension() == ".partial")
        return entry.path().string();
    }
    return "";
  };
  ASSERT_TRUE(testing::WaitUntil([&] { return !partial().empty(); }, 60)) << ReadFileBytes(log);
  testing::KillHard(pid);
  {
    DatasetDb killed(again, DatasetDb::Mode::kReadOnly);
    ASSERT_TRUE(killed.Runs().empty()) << "killed after the run was stored: " << ReadFileBytes(log);
  }
  const testing::CommandResult resumed = Workbench(evaluate + again + " 2>&1");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_NE(resumed.output.find("evaluate: resuming: "), std::string::npos) << resumed.output;
  EXPECT_TRUE(partial().empty());
  DatasetDb one(db, DatasetDb::Mode::kReadOnly), two(again, DatasetDb::Mode::kReadOnly);
  ASSERT_EQ(one.Runs().size(), 1u);
  ASSERT_EQ(two.Runs().size(), 1u);
  auto untimed = [](std::map<std::string, double> metrics) {  // latencies are the clock's
    for (auto it = metrics.begin(); it != metrics.end();)
      it = it->first.find("latency") != std::string::npos ? metrics.erase(it) : std::next(it);
    return metrics;
  };
  const std::map<std::string, double> expected = untimed(one.RunMetrics(one.Runs()[0].id));
  EXPECT_EQ(untimed(two.RunMetrics(two.Runs()[0].id)), expected);
  EXPECT_GT(expected.size(), 10u);
  auto detections = [](const std::string& path) {
    Database file(path, Database::Mode::kReadOnly);
    Statement rows(&file, "SELECT frame_id, class, x, y, score FROM run_detections ORDER BY rowid");
    std::vector<std::string> out;
    while (rows.Step()) {
      out.push_back(std::to_string(rows.ColumnInt(0)) + " " + rows.ColumnText(1) + " " +
                    std::to_string(rows.ColumnDouble(2)) + " " +
                    std::to_string(rows.ColumnDouble(3)) + " " +
                    std::to_string(rows.ColumnDouble(4)));
    }
    return out;
  };
  EXPECT_EQ(detections(again), detections(db));
  EXPECT_FALSE(detections(db).empty());
}

}  // namespace
}  // namespace furn
