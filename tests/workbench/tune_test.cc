// workbench tune: the search space file, trial generation (grid, random,
// base first, every value checked before anything runs), options files, and
// the whole command on a small procedural dataset: trials stored as runs,
// models cached, a rerun resumes, the report and best_options.json.
#include "workbench/pipelines/tune.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "tests/test_util.h"
#include "tests/workbench/dataset_dump.h"
#include "workbench/pipelines/evaluate.h"

namespace furn {
namespace {

testing::CommandResult Workbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
}

std::string SpaceError(const std::string& text) {
  return testing::ErrorOf([&] { ParseTuneSpace(text, "space.json"); });
}

TEST(TuneSpace, ListsAndRangesAreRead) {
  const TuneSpace space = ParseTuneSpace(
      R"({"trainer.region_growing.delta_m": [0.03, 0.05],
          "detector.relative_threshold": {"min": 0.1, "max": 0.3, "steps": 5},
          "trainer.region_growing.min_segment_size": {"min": 10, "max": 40},
          "detector.cell_m": {"min": 0.01, "max": 0.04, "log": true},
          "trainer.vocabulary.kind": ["rim", "kmeans"]})",
      "space.json");
  ASSERT_EQ(space.parameters.size(), 5u);
  EXPECT_EQ(space.parameters[0].path, "trainer.region_growing.delta_m");
  EXPECT_EQ(space.parameters[0].values, (std::vector<std::string>{"0.03", "0.05"}));
  EXPECT_TRUE(space.parameters[1].is_range);
  EXPECT_EQ(space.parameters[1].steps, 5);
  EXPECT_FALSE(space.parameters[1].integer);
  EXPECT_TRUE(space.parameters[2].integer);
  EXPECT_TRUE(space.parameters[3].log);
  EXPECT_EQ(space.parameters[4].values[1], "\"kmeans\"");
}

TEST(TuneSpace, BadSpacesAreRefusedNamingTheParameterAndTheRule) {
  EXPECT_NE(SpaceError("{nope").find("space.json: not JSON"), std::string::npos);
  EXPECT_NE(SpaceError("{}").find("space.json: the search space must be"), std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.relative_treshold": [0.1]})")
                .find("unknown parameter 'detector.relative_treshold'"),
            std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.fit": [1]})").find("unknown parameter 'detector.fit'"),
            std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.cell_m": []})").find("'detector.cell_m' has an empty list"),
            std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.cell_m": {"min": 0.05, "max": 0.01}})")
                .find("'detector.cell_m' range is empty (min 0.05 > max 0.01)"),
            std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.cell_m": {"min": 0.01}})").find("needs numbers min and max"),
            std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.cell_m": {"min": 0.01, "max": 0.02, "steps": 0}})")
                .find("steps must be an integer in 1..1000"),
            std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.cell_m": {"min": 0, "max": 0.02, "log": true}})")
                .find("log range needs min > 0"),
            std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.cell_m": {"min": 0.01, "max": 0.02, "stride": 2}})")
                .find("unknown key 'stride'"),
            std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.seed": [1, 2]})").find("is a seed"), std::string::npos);
  EXPECT_NE(SpaceError(R"({"detector.cell_m": 0.02})").find("must be a list of values or a range"),
            std::string::npos);
}

TEST(TuneTrials, GridCoversEveryPointOnceWithTheBaseFirst) {
  const TuneSpace space = ParseTuneSpace(
      R"({"detector.relative_threshold": {"min": 0.1, "max": 0.3, "steps": 3},
          "trainer.region_growing.delta_m": [0.04, 0.06]})",
      "space.json");
  const std::vector<TuneTrial> trials =
      MakeTrials(space, TuneStrategy::kGrid, 100, 1, TrainingOptions{}, DetectorOptions{});
  ASSERT_EQ(trials.size(), 7u);  // the base plus 3 x 2 grid points
  EXPECT_EQ(trials[0].index, 0);
  EXPECT_EQ(trials[0].values, (std::vector<std::string>{"0.15", "0.05"}));  // the defaults
  std::set<std::pair<double, double>> points;
  for (size_t k = 1; k < trials.size(); ++k) {
    EXPECT_EQ(trials[k].index, static_cast<int>(k));
    points.insert(
        {trials[k].detector.relative_threshold, trials[k].training.trainer.region_growing.delta_m});
  }
  EXPECT_EQ(points.size(), 6u);
  EXPECT_EQ(points.count({0.2, 0.06}), 1u);
  EXPECT_EQ(points.count({0.3, 0.04}), 1u);

  // Fewer trials than points: a seeded sample, the same for the same seed.
  const auto few =
      MakeTrials(space, TuneStrategy::kGrid, 4, 7, TrainingOptions{}, DetectorOptions{});
  ASSERT_EQ(few.size(), 4u);
  const auto again =
      MakeTrials(space, TuneStrategy::kGrid, 4, 7, TrainingOptions{}, DetectorOptions{});
  for (size_t k = 0; k < few.size(); ++k) EXPECT_EQ(few[k].values, again[k].values);
}

TEST(TuneTrials, RandomDrawsStayInTheirRangesAndFollowTheSeed) {
  const TuneSpace space = ParseTuneSpace(
      R"({"detector.relative_threshold": {"min": 0.1, "max": 0.3},
          "trainer.region_growing.min_segment_size": {"min": 10, "max": 40},
          "detector.cell_m": {"min": 0.01, "max": 0.04, "log": true},
          "trainer.vocabulary.kind": ["rim", "kmeans"]})",
      "space.json");
  const auto trials =
      MakeTrials(space, TuneStrategy::kRandom, 30, 3, TrainingOptions{}, DetectorOptions{});
  ASSERT_EQ(trials.size(), 30u);
  std::set<int> kinds;
  for (size_t k = 1; k < trials.size(); ++k) {
    EXPECT_GE(trials[k].detector.relative_threshold, 0.1);
    EXPECT_LE(trials[k].detector.relative_threshold, 0.3);
    EXPECT_GE(trials[k].training.trainer.region_growing.min_segment_size, 10);
    EXPECT_LE(trials[k].training.trainer.region_growing.min_segment_size, 40);
    EXPECT_EQ(trials[k].values[1].find('.'), std::string::npos);  // an integer
    EXPECT_GE(trials[k].detector.cell_m, 0.01 * 0.9999);
    EXPECT_LE(trials[k].detector.cell_m, 0.04 * 1.0001);
    kinds.insert(static_cast<int>(trials[k].training.trainer.vocabulary.kind));
  }
  EXPECT_EQ(kinds.size(), 2u);
  const auto same =
      MakeTrials(space, TuneStrategy::kRandom, 30, 3, TrainingOptions{}, DetectorOptions{});
  const auto other =
      MakeTrials(space, TuneStrategy::kRandom, 30, 4, TrainingOptions{}, DetectorOptions{});
  EXPECT_EQ(same[17].values, trials[17].values);
  EXPECT_NE(other[17].values, trials[17].values);
}

TEST(TuneTrials, ValuesTheOptionsRefuseFailBeforeAnyTrial) {
  auto error = [](const std::string& text) {
    return testing::ErrorOf([&] {
      MakeTrials(ParseTuneSpace(text, "space.json"),
                 TuneStrategy::kRandom,
                 5,
                 1,
                 TrainingOptions{},
                 DetectorOptions{});
    });
  };
  // A range whose far end is out of bounds fails even if no draw lands there.
  const std::string threshold =
      error(R"({"detector.relative_threshold": {"min": 0.1, "max": 1.5}})");
  EXPECT_NE(threshold.find("tune space detector.relative_threshold = 1.5"), std::string::npos)
      << threshold;
  EXPECT_NE(error(R"({"trainer.region_growing.alpha_deg": [30, 120]})").find("alpha"),
            std::string::npos);
  EXPECT_NE(error(R"({"trainer.vocabulary.kind": ["rim", "gmm"]})").find("\"rim\" or \"kmeans\""),
            std::string::npos);
  EXPECT_NE(error(R"({"detector.cell_m": ["wide"]})").find("wrong type"), std::string::npos);
}

TEST(OptionsFile, TrainerOptionsRoundTripAndBadKeysAreNamed) {
  TrainingOptions options;
  options.trainer.region_growing.delta_m = 0.07;
  options.trainer.vocabulary.kind = VocabularyKind::kKMeans;
  options.scan.azimuths = 12;
  const std::string file = OptionsFileJson(options, DetectorOptions{});
  const TrainingOptions back = TrainingOptionsFromJson(file, "best.json");
  EXPECT_EQ(TrainingOptionsJson(back), TrainingOptionsJson(options));
  EXPECT_EQ(back.trainer.vocabulary.kind, VocabularyKind::kKMeans);
  EXPECT_EQ(back.scan.azimuths, 12);
  EXPECT_NO_THROW(DetectorOptionsFromJson(file, "best.json"));  // the same file detects
  // ... and a typo in its trainer part is refused there too, not only by train.
  EXPECT_NE(testing::ErrorOf([] {
              DetectorOptionsFromJson(
                  R"({"trainer": {"vocabulary": {"wordz": 3}}, "detector": {"min_score": 0.3}})",
                  "best.json");
            }).find("unknown trainer option 'vocabulary.wordz'"),
            std::string::npos);

  auto error = [](const std::string& text) {
    return testing::ErrorOf([&] { TrainingOptionsFromJson(text, "best.json"); });
  };
  EXPECT_NE(error(R"({"trainer": {"region_growing": {"delta": 0.05}}})")
                .find("best.json: unknown trainer option 'region_growing.delta'"),
            std::string::npos);
  EXPECT_NE(error(R"({"detector": {"cell_m": 0.02}})").find("has no \"trainer\" options"),
            std::string::npos);
  EXPECT_NE(error(R"({"region_growing": {"alpha_deg": "wide"}})").find("wrong type"),
            std::string::npos);
  EXPECT_NE(error(R"({"scan": {"azimuths": 0}})").find("scan azimuths must be in 1..360"),
            std::string::npos);
}

// The whole command on a small procedural dataset (8 rooms: val and test
// both present).
TEST(TuneCommand, TrialsAreRunsResumeAndTheReportAndBestOptionsWork) {
  const std::string dir = testing::ScratchDir();
  const std::string db = dir + "/small.db";
  ASSERT_EQ(
      Workbench("generate --catalog procedural:4 --rooms 8 --frames 2 --seed 5 --quiet --out " + db)
          .exit_code,
      0);
  // One trainer parameter (two values: one model to train besides the base),
  // one detector parameter.
  testing::WriteText(dir + "/space.json",
                     R"({"trainer.region_growing.delta_m": [0.05, 0.04],
                         "detector.relative_threshold": [0.15, 0.6]})");
  // Cheap training for the test: fewer views, a k-means vocabulary.
  testing::WriteText(dir + "/base.json",
                     R"({"trainer": {"scan": {"azimuths": 6},
                                     "vocabulary": {"kind": "kmeans", "words": 20}}})");
  const std::string common = "tune --catalog procedural:4 --quiet --db " + db + " --space " + dir +
                             "/space.json --options " + dir + "/base.json --trials 4 --work-dir " +
                             dir + "/work --out " + dir + "/report";
  const std::string tune = common + " --strategy grid";
  const testing::CommandResult first = Workbench(tune);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_NE(first.output.find("4 trials (0 done before), 2 models trained"), std::string::npos)
      << first.output;
  size_t tune_runs = 0, test_runs = 0;
  {
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    for (const RunRecord& run : dataset.Runs()) {
      if (run.kind == "tune") {
        ++tune_runs;
        EXPECT_EQ(run.split, Split::kVal);
        const auto options = nlohmann::json::parse(run.options_json);
        EXPECT_TRUE(options.contains("trainer"));
        EXPECT_EQ(options["tune"]["parameters"].size(), 2u);
        EXPECT_GT(dataset.RunMetrics(run.id).count("mAP@10cm"), 0u);
      }
      test_runs += run.kind == "tune-test";
    }
  }
  EXPECT_EQ(tune_runs, 4u);
  EXPECT_GE(test_runs, 1u);  // base and best on the test split (one run when the base wins)
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir + "/work/models"),
                          std::filesystem::directory_iterator()),
            2);

  // The same command again: nothing runs or trains.
  const testing::CommandResult again = Workbench(tune);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("4 trials (4 done before), 0 models trained"), std::string::npos)
      << again.output;
  EXPECT_EQ(DatasetDb(db, DatasetDb::Mode::kReadOnly).Runs().size(), tune_runs + test_runs);

  // Two detector seeds per trial: one more run per trial, no training, and
  // the trials' metrics are the mean of their two runs.
  const testing::CommandResult seeds = Workbench(tune + " --seeds 2");
  ASSERT_EQ(seeds.exit_code, 0) << seeds.output;
  EXPECT_NE(seeds.output.find("4 trials (0 done before), 0 models trained"), std::string::npos)
      << seeds.output;
  {
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    std::map<int, std::vector<double>> map_by_trial;  // val mAP@10cm per seed
    for (const RunRecord& run : dataset.Runs()) {
      if (run.kind != "tune") continue;
      const auto tune_json = nlohmann::json::parse(run.options_json)["tune"];
      map_by_trial[tune_json["trial"].get<int>()].push_back(
          dataset.RunMetrics(run.id).at("mAP@10cm"));
    }
    ASSERT_EQ(map_by_trial.size(), 4u);
    for (const auto& [trial, values] : map_by_trial) EXPECT_EQ(values.size(), 2u) << trial;
    const double mean = (map_by_trial[0][0] + map_by_trial[0][1]) / 2;
    char text[64];
    std::snprintf(text, sizeof(text), "trial 0 (1 of 4) (done before): mAP@10cm = %.3f", mean);
    EXPECT_EQ(Workbench(tune + " --seeds 2").output.find(text) != std::string::npos, true) << text;
  }

  // The report: the ranking, an effect plot per parameter, every image loads.
  const std::string html = ReadFileBytes(dir + "/report/index.html");
  EXPECT_NE(html.find("Trials, ranked"), std::string::npos);
  EXPECT_NE(html.find("trainer.region_growing.delta_m"), std::string::npos);
  for (const char* png : {"progress.png", "effect_0.png", "effect_1.png"})
    EXPECT_GT(ReadFileBytes(dir + "/report/" + png).size(), 1000u) << png;
  if (testing::RunCommand("command -v chromium").exit_code == 0) {
    const testing::CommandResult browser = testing::RunCommand(
        "chromium --headless --no-sandbox --disable-gpu --virtual-time-budget=5000 --dump-dom "
        "file://" +
        dir + "/report/index.html");
    EXPECT_NE(browser.output.find("images loaded: 3 of 3"), std::string::npos) << browser.output;
  }

  // best_options.json trains and evaluates.
  const std::string best = dir + "/report/best_options.json";
  const TrainingOptions training = TrainingOptionsFromJson(ReadFileBytes(best), best);
  EXPECT_TRUE(training.trainer.region_growing.delta_m == 0.05 ||
              training.trainer.region_growing.delta_m == 0.04);
  EXPECT_EQ(training.scan.azimuths, 6);  // the base options carry through
  const testing::CommandResult trained =
      Workbench("train --no-vote-net --catalog procedural:4 --quiet --options " + best + " --out " +
                dir + "/best.fcm");
  ASSERT_EQ(trained.exit_code, 0) << trained.output;
  const testing::CommandResult evaluated =
      Workbench("evaluate --quiet --split val --options " + best + " --model " + dir +
                "/best.fcm --db " + db);
  ASSERT_EQ(evaluated.exit_code, 0) << evaluated.output;

  // Bad input: one line, exit 1, nothing run.
  const size_t runs_before = DatasetDb(db, DatasetDb::Mode::kReadOnly).Runs().size();
  testing::WriteText(dir + "/typo.json", R"({"detector.relative_treshold": [0.1]})");
  const testing::CommandResult typo =
      Workbench("tune --catalog procedural:4 --quiet --db " + db + " --space " + dir +
                "/typo.json --work-dir " + dir + "/work --out " + dir + "/typo");
  EXPECT_EQ(typo.exit_code, 1);
  EXPECT_NE(typo.output.find("unknown parameter 'detector.relative_treshold'"), std::string::npos)
      << typo.output;
  const testing::CommandResult strategy = Workbench(common + " --strategy annealing");
  EXPECT_EQ(strategy.exit_code, 1);
  EXPECT_NE(strategy.output.find("must be grid or random"), std::string::npos) << strategy.output;
  const testing::CommandResult objective = Workbench(tune + " --objective mAP@7cm");
  EXPECT_EQ(objective.exit_code, 1);
  EXPECT_NE(objective.output.find("objective 'mAP@7cm' is not a metric of evaluation runs"),
            std::string::npos)
      << objective.output;
  EXPECT_EQ(DatasetDb(db, DatasetDb::Mode::kReadOnly).Runs().size(), runs_before);
}

// Issue 31 without a cluster: `tune --shards 2 --emit-only` writes the array
// job's scripts; its two tasks run side by side (as on two nodes), both
// needing the base model, which the locked cache trains once; the final
// script stores the trials as the one-process tune stores them.
TEST(TuneCommand, TrialTasksFromTheJobScriptsGiveTheOneProcessSearch) {
  const std::string dir = testing::ScratchDir();
  ASSERT_EQ(
      Workbench("generate --catalog procedural:4 --rooms 8 --frames 2 --seed 5 --quiet --out " +
                dir + "/one.db")
          .exit_code,
      0);
  std::filesystem::copy_file(dir + "/one.db", dir + "/array.db");
  testing::WriteText(dir + "/space.json",
                     R"({"detector.relative_threshold": [0.15, 0.6],
                         "detector.min_score": [0.0, 0.3]})");
  testing::WriteText(dir + "/base.json",
                     R"({"trainer": {"scan": {"azimuths": 6},
                                     "vocabulary": {"kind": "kmeans", "words": 20}}})");
  auto tune = [&](const std::string& db, const std::string& name) {
    return "tune --catalog procedural:4 --quiet --strategy grid --trials 3 --space " + dir +
           "/space.json --options " + dir + "/base.json --db " + dir + "/" + db +
           ".db --work-dir " + dir + "/work-" + name + " --out " + dir + "/report-" + name;
  };
  const testing::CommandResult one = Workbench(tune("one", "one"));
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const std::string job = dir + "/job";
  const testing::CommandResult emit =
      Workbench(tune("array", "array") + " --shards 2 --emit-only --job-dir " + job);
  ASSERT_EQ(emit.exit_code, 0) << emit.output;
  EXPECT_NE(emit.output.find("--array=0,1"), std::string::npos) << emit.output;
  const testing::CommandResult tasks = testing::RunCommand(
      "(SLURM_ARRAY_TASK_ID=0 bash " + job + "/task.sbatch & SLURM_ARRAY_TASK_ID=1 bash " + job +
      "/task.sbatch & wait)");
  EXPECT_TRUE(std::filesystem::exists(job + "/status/task-0.ok")) << tasks.output;
  EXPECT_TRUE(std::filesystem::exists(job + "/status/task-1.ok")) << tasks.output;
  size_t trainings = 0;
  for (size_t at = tasks.output.find("training a model"); at != std::string::npos;
       at = tasks.output.find("training a model", at + 1))
    ++trainings;
  EXPECT_EQ(trainings, 1u) << tasks.output;
  EXPECT_NE(tasks.output.find("trial shard 1/2: 1 trials evaluated"), std::string::npos)
      << tasks.output;
  std::filesystem::copy_file(dir + "/array.db", dir + "/lost.db");
  const testing::CommandResult final_step = testing::RunCommand("bash " + job + "/final.sbatch");
  ASSERT_EQ(final_step.exit_code, 0) << final_step.output;
  EXPECT_NE(final_step.output.find("3 trials (0 done before), 0 models trained"), std::string::npos)
      << final_step.output;
  EXPECT_EQ(testing::DumpRuns(dir + "/array.db"), testing::DumpRuns(dir + "/one.db"));
  EXPECT_EQ(ReadFileBytes(dir + "/report-array/best_options.json"),
            ReadFileBytes(dir + "/report-one/best_options.json"));

  // Trial files of another search, or one lost: the final step names the
  // file before it stores any trial (issue 39).
  const std::string results = " --results-dir " + job + "/trials";
  const size_t runs_before = DatasetDb(dir + "/lost.db", DatasetDb::Mode::kReadOnly).Runs().size();
  const testing::CommandResult other = Workbench(tune("lost", "array") + results + " --seed 9");
  EXPECT_EQ(other.exit_code, 1) << other.output;
  EXPECT_NE(other.output.find("was evaluated with other options"), std::string::npos)
      << other.output;
  EXPECT_EQ(DatasetDb(dir + "/lost.db", DatasetDb::Mode::kReadOnly).Runs().size(), runs_before)
      << "a refusing final step stored a trial";
  std::filesystem::remove(job + "/trials/trial-2-seed-0.json");
  const testing::CommandResult lost = Workbench(tune("lost", "array") + results);
  EXPECT_EQ(lost.exit_code, 1) << lost.output;
  EXPECT_NE(lost.output.find("trial-2-seed-0.json: missing: trial 2"), std::string::npos)
      << lost.output;
  const testing::CommandResult too_many =
      Workbench(tune("array", "array") + " --shards 5 --emit-only --job-dir " + dir + "/job5");
  EXPECT_EQ(too_many.exit_code, 1);
  EXPECT_NE(too_many.output.find("more tasks than --trials 3"), std::string::npos)
      << too_many.output;
}

TEST(TuneOptions, TestSplitNoneIsAcceptedAndBadSplitsAreNamed) {
  TuneOptions options;
  options.db_path = "d.db";
  options.space_path = "s.json";
  options.work_dir = "w";
  options.out_dir = "o";
  options.test_split = "none";  // documented: no held-out evaluation
  EXPECT_NO_THROW(options.Check());
  options.test_split = "";
  EXPECT_NO_THROW(options.Check());
  options.test_split = "tset";
  EXPECT_NE(testing::ErrorOf([&] { options.Check(); }).find("test split 'tset'"),
            std::string::npos);
  options.test_split = "test";
  options.split = "none";
  EXPECT_NE(testing::ErrorOf([&] { options.Check(); }).find("split 'none' must be"),
            std::string::npos);
}

}  // namespace
}  // namespace furn
