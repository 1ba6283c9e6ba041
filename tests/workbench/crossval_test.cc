// Protocol E end to end on the procedural catalog: generate leave-models-out
// rooms, crossval (a model per fold, a run per fold, the aggregate run),
// report, model reuse, the committed CI baseline, and clear errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/model/trained_model.h"
#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "db/sqlite.h"
#include "scenes/model_folds.h"
#include "tests/test_util.h"

namespace furn {
namespace {

testing::CommandResult Workbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
}

TEST(Crossval, LeaveModelsOutFoldsAreTrainedEvaluatedAggregatedAndGated) {
  const std::string dir = testing::ScratchDir();
  const std::string db = dir + "/folds.db";
  ASSERT_EQ(Workbench("generate --catalog procedural:4 --rooms 9 --frames 2 --seed 5 "
                      "--model-folds 3 --quiet --out " +
                      db)
                .exit_code,
            0);
  {  // Room k's targets are fold k % 3's models only.
    const ModelFolds folds = AssignModelFolds(OpenCatalog("procedural:4"), 3, 1);
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    int targets = 0;
    for (int64_t room : dataset.RoomIds()) {
      for (const ObjectRecord& object : dataset.ReadRoom(room, false).objects) {
        if (!object.furniture_class) continue;
        ++targets;
        EXPECT_EQ(folds.fold_of_model.at(object.model_id), room % 3) << object.model_id;
      }
    }
    EXPECT_GT(targets, 20);
  }

  const std::string work = dir + "/models";
  const testing::CommandResult run =
      Workbench("crossval --no-vote-net --quiet --db " + db + " --work-dir " + work);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("leave-models-out (protocol E): 3 folds"), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("without the scorer (fixed gates)"), std::string::npos) << run.output;
  {  // Per fold a fixed-gates run, then a run with the fold's scorer (nested:
     // learnt from the other folds' hypotheses); the aggregate's mean is the
     // scored folds' mean.
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    const std::vector<RunRecord> runs = dataset.Runs();
    ASSERT_EQ(runs.size(), 7u);
    double sum = 0, gates = 0;
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(runs[k].kind, "crossval-gates");
      gates += dataset.RunMetrics(runs[k].id).at("mAP@10cm");
      EXPECT_EQ(runs[3 + k].kind, "crossval-fold");
      EXPECT_NE(runs[3 + k].model_path.find("-scored.fcm"), std::string::npos);
      EXPECT_EQ(LoadTrainedModel(runs[3 + k].model_path).scorer.empty(), false);
      sum += dataset.RunMetrics(runs[3 + k].id).at("mAP@10cm");
    }
    EXPECT_EQ(runs[6].kind, "crossval");
    const std::map<std::string, double> aggregate = dataset.RunMetrics(runs[6].id);
    EXPECT_NEAR(aggregate.at("mAP@10cm"), sum / 3, 1e-12);
    EXPECT_NEAR(aggregate.at("gates/mAP@10cm"), gates / 3, 1e-12);
    EXPECT_TRUE(aggregate.count("spread/mAP@10cm"));
    EXPECT_TRUE(aggregate.count("calibration_error"));
    EXPECT_EQ(aggregate.at("folds"), 3);
    EXPECT_EQ(aggregate.at("frames"), 18);  // a total, not a mean
  }
  int models = 0;
  for (const auto& entry : std::filesystem::directory_iterator(work))
    models += entry.path().extension() == ".fcm";
  EXPECT_EQ(models, 6);  // per fold: trained, and with its scorer

  // The all-folds scorer goes into a model with `train --scorer`.
  ASSERT_TRUE(std::filesystem::exists(work + "/scorer.yml"));
  ASSERT_EQ(Workbench("train --no-vote-net --catalog procedural:4 --quiet --azimuths 4 --words 20 "
                      "--vocab kmeans "
                      "--scorer " +
                      work + "/scorer.yml --out " + dir + "/scored.fcm")
                .exit_code,
            0);
  const testing::CommandResult info = Workbench("model info " + dir + "/scored.fcm");
  EXPECT_NE(info.output.find("scorer:      random forest from"), std::string::npos) << info.output;
  WriteFileAtomically(dir + "/bad.yml", "not a scorer\n");
  const testing::CommandResult bad =
      Workbench("train --no-vote-net --catalog procedural:4 --quiet --scorer " + dir +
                "/bad.yml --out " + dir + "/bad.fcm");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.output.find("bad.yml: not a hypothesis scorer"), std::string::npos) << bad.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.fcm"));

  // The CI gate: no metric worse than the committed baseline.
  const testing::CommandResult gate = Workbench(
      "regress --db " + db + " --baseline " FURN_SOURCE_DIR "/tests/baselines/crossval_small.json");
  EXPECT_EQ(gate.exit_code, 0) << gate.output;

  // The report: the fold table and plot, and each fold's own report.
  const testing::CommandResult report =
      Workbench("report --db " + db + " --out " + dir + "/report");
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const std::string html = ReadFileBytes(dir + "/report/index.html");
  EXPECT_NE(html.find("Protocol E"), std::string::npos);
  EXPECT_NE(html.find("fold-2/index.html"), std::string::npos);
  // The summary run has no model or dataset hash of its own: said, not left blank.
  EXPECT_NE(html.find("<td>– (one per fold run)</td>"), std::string::npos);
  EXPECT_EQ(html.find(" · </td>"), std::string::npos);
  EXPECT_GT(ReadFileBytes(dir + "/report/folds_ap.png").size(), 1000u);
  EXPECT_TRUE(std::filesystem::exists(dir + "/report/fold-0/pr_detection.png"));
  EXPECT_NE(html.find("fixed gates"), std::string::npos);
  EXPECT_GT(ReadFileBytes(dir + "/report/reliability.png").size(), 1000u);
  EXPECT_GT(ReadFileBytes(dir + "/report/fold-0/reliability.png").size(), 1000u);

  // Again: the fold models are reused, and the result is the same.
  const testing::CommandResult again =
      Workbench("crossval --no-vote-net --db " + db + " --work-dir " + work);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("model reused"), std::string::npos) << again.output;
  EXPECT_EQ(Workbench("regress --db " + db + " --run 14 --baseline 7 --tolerance 0").exit_code, 0);
}

TEST(Crossval, DatasetsWithoutFoldsAndImpossibleFoldsAreClearErrors) {
  const std::string dir = testing::ScratchDir();
  ASSERT_EQ(Workbench("generate --catalog procedural:4 --rooms 2 --frames 1 --quiet --out " + dir +
                      "/plain.db")
                .exit_code,
            0);
  const testing::CommandResult plain =
      Workbench("crossval --no-vote-net --db " + dir + "/plain.db --work-dir " + dir + "/m");
  EXPECT_EQ(plain.exit_code, 1);
  EXPECT_NE(plain.output.find("was not generated with leave-models-out folds"), std::string::npos)
      << plain.output;
  const testing::CommandResult too_many = Workbench(
      "generate --catalog procedural:4 --rooms 6 --model-folds 5 --quiet --out " + dir + "/x.db");
  EXPECT_EQ(too_many.exit_code, 1);
  EXPECT_NE(too_many.output.find("fewer than the 5 leave-models-out folds"), std::string::npos)
      << too_many.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.db"));
  const testing::CommandResult one = Workbench(
      "generate --catalog procedural:4 --rooms 6 --model-folds 1 --quiet --out " + dir + "/y.db");
  EXPECT_EQ(one.exit_code, 1);
  EXPECT_NE(one.output.find("must be 0 (off) or in 2..20"), std::string::npos) << one.output;
  // The dataset's folds come from its catalog: one whose models are not
  // those of the rooms (here: the rooms' model ids changed) disagrees.
  ASSERT_EQ(Workbench("generate --catalog procedural:4 --rooms 3 --frames 1 --model-folds 3 "
                      "--quiet --out " +
                      dir + "/f.db")
                .exit_code,
            0);
  {
    Database database(dir + "/f.db", Database::Mode::kReadWriteExisting);
    database.Execute("PRAGMA foreign_keys = OFF");
    database.Execute("UPDATE models SET id = 'other/' || id");
    database.Execute("UPDATE objects SET model_id = 'other/' || model_id");
  }
  const testing::CommandResult other =
      Workbench("crossval --no-vote-net --db " + dir + "/f.db --work-dir " + dir + "/m");
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_NE(other.output.find("use the catalog the dataset was generated from"), std::string::npos)
      << other.output;
}

// A learned protocol E at a budget below the default model's says so beside
// its figure (issue 70), with the default budget's measured figure.
TEST(Crossval, ALearnedRunBelowTheDefaultBudgetSaysHowFarItIs) {
  const std::string dir = testing::ScratchDir();
  const std::string db = dir + "/folds.db";
  ASSERT_EQ(Workbench("generate --catalog procedural:4 --rooms 3 --frames 1 --seed 5 "
                      "--model-folds 3 --quiet --out " +
                      db)
                .exit_code,
            0);
  const testing::CommandResult run = Workbench(
      "crossval --vote-rooms 3 --vote-frames 1 --vote-epochs 1 --vote-threads 1 "
      "--quiet --db " +
      db + " --work-dir " + dir + "/models");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("fold networks at 3 rooms x 1 epochs, not the default model's 2400 x "
                            "10: mAP@10cm"),
            std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("0.552 at the default budget (nine fold networks;"), std::string::npos)
      << run.output;
}

}  // namespace
}  // namespace furn
