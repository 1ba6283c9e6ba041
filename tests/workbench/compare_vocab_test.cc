// Protocol D through the CLI: three vocabularies trained on the procedural
// catalog, each evaluated as its own run (slow: three trainings).
#include <gtest/gtest.h>

#include "db/dataset_db.h"
#include "tests/test_util.h"

namespace furn {
namespace {

TEST(CompareVocab, TrainsAndEvaluatesEveryVocabulary) {
  const std::string dir = testing::ScratchDir();
  const std::string db = dir + "/small.db";
  const std::string workbench = FURN_WORKBENCH_BINARY;
  ASSERT_EQ(testing::RunCommand(workbench +
                                " generate --catalog procedural:4 --rooms 3 --frames 2 "
                                "--seed 5 --quiet --out " +
                                db)
                .exit_code,
            0);
  const testing::CommandResult run = testing::RunCommand(
      workbench +
      " evaluate --compare-vocab --catalog procedural:4 --seeds 1 --quiet --split all "
      "--work-dir " +
      dir + " --db " + db);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const char* name : {"kmeans", "rim-kmeans-init", "rim-pca-init"})
    EXPECT_NE(run.output.find(name), std::string::npos) << run.output;
  size_t means = 0;
  for (size_t at = run.output.find("mean mAP@10cm"); at != std::string::npos;
       at = run.output.find("mean mAP@10cm", at + 1)) {
    ++means;
  }
  EXPECT_EQ(means, 3u) << run.output;
  DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
  const std::vector<RunRecord> runs = dataset.Runs();
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runs[0].kind, "compare-vocab");
  EXPECT_EQ(runs[2].label, "rim-pca-init seed 1");
  // Without --work-dir: one line, exit 1.
  EXPECT_EQ(
      testing::RunCommand(workbench + " evaluate --compare-vocab --catalog procedural:4 --db " + db)
          .exit_code,
      1);
}

}  // namespace
}  // namespace furn
