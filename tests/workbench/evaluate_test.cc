// generate -> train -> evaluate -> regress through the CLI on a small
// procedural dataset; the run is gated by the committed baseline
// tests/baselines/small_eval.json (the CI evaluation).
#include <gtest/gtest.h>

#include <cstdio>
#include <nlohmann/json.hpp>

#include "core/file_util.h"
#include "db/dataset_db.h"
#include "tests/test_util.h"

namespace furn {
namespace {

testing::CommandResult Workbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
}

TEST(Evaluate, SmallRunIsStoredAndGatedByTheCommittedBaseline) {
  const std::string dir = testing::ScratchDir();
  const std::string db = dir + "/small.db", model = dir + "/small.fcm";
  ASSERT_EQ(
      Workbench("generate --catalog procedural:4 --rooms 4 --frames 2 --seed 5 --quiet --out " + db)
          .exit_code,
      0);
  ASSERT_EQ(Workbench("train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 8 --quiet "
                      "--out " +
                      model)
                .exit_code,
            0);
  const testing::CommandResult run =
      Workbench("evaluate --quiet --split all --model " + model + " --db " + db);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("mAP@10cm"), std::string::npos) << run.output;

  {  // The run row: provenance, options, metrics, detections, timings.
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    const std::vector<RunRecord> runs = dataset.Runs();
    ASSERT_EQ(runs.size(), 1u);
    EXPECT_EQ(runs[0].git_commit.size(), 40u);  // a commit hash
    EXPECT_EQ(runs[0].model_hash.size(), 32u);
    EXPECT_NE(runs[0].options_json.find("relative_threshold"), std::string::npos);
    EXPECT_NE(runs[0].results_json.find("A/chair"), std::string::npos);
    EXPECT_EQ(dataset.RunMetrics(runs[0].id).at("frames"), 8);
  }

  // The report: a folder that opens offline, every image present and loaded
  // in headless Chromium with no console error.
  const std::string report = dir + "/report";
  const testing::CommandResult wrote = Workbench("report --db " + db + " --out " + report);
  ASSERT_EQ(wrote.exit_code, 0) << wrote.output;
  const std::string html = ReadFileBytes(report + "/index.html");
  for (const char* png : {"pr_detection.png", "pr_paper.png", "confusion.png", "latency.png"}) {
    EXPECT_NE(html.find(std::string("src=\"") + png), std::string::npos) << png;
    EXPECT_GT(ReadFileBytes(report + "/" + png).size(), 1000u) << png;
  }
  EXPECT_EQ(html.find("http://"), std::string::npos);  // nothing from the network
  EXPECT_EQ(html.find("https://"), std::string::npos);
  if (testing::RunCommand("command -v chromium").exit_code != 0) {
    ADD_FAILURE() << "chromium is missing (tools/install_deps.sh installs it)";
  } else {
    const testing::CommandResult browser = testing::RunCommand(
        "chromium --headless --no-sandbox --disable-gpu --enable-logging=stderr --v=0 "
        "--virtual-time-budget=5000 --dump-dom file://" +
        report + "/index.html");
    ASSERT_EQ(browser.exit_code, 0) << browser.output;
    const size_t at = browser.output.find("images loaded: ");
    ASSERT_NE(at, std::string::npos) << browser.output;
    int loaded = -1, total = -2;
    std::sscanf(browser.output.c_str() + at, "images loaded: %d of %d", &loaded, &total);
    EXPECT_GT(total, 4);
    EXPECT_EQ(loaded, total);
    EXPECT_EQ(browser.output.find("CONSOLE"), std::string::npos) << browser.output;
    EXPECT_EQ(browser.output.find("Uncaught"), std::string::npos) << browser.output;
  }

  // The CI gate: no metric worse than the committed baseline.
  const testing::CommandResult gate = Workbench(
      "regress --db " + db + " --baseline " FURN_SOURCE_DIR "/tests/baselines/small_eval.json");
  EXPECT_EQ(gate.exit_code, 0) << gate.output;

  // A deliberately worse threshold: regress names what got worse.
  ASSERT_EQ(
      Workbench("evaluate --quiet --split all --min-score 0.99 --model " + model + " --db " + db)
          .exit_code,
      0);
  const testing::CommandResult worse = Workbench("regress --db " + db + " --run 2 --baseline 1");
  EXPECT_EQ(worse.exit_code, 1) << worse.output;
  EXPECT_NE(worse.output.find("REGRESSION mAP@10cm"), std::string::npos) << worse.output;
  EXPECT_EQ(Workbench("regress --db " + db + " --run 1 --baseline 1").exit_code, 0);

  // History over the two runs.
  const testing::CommandResult history =
      Workbench("history --db " + db + " --out " + dir + "/history");
  ASSERT_EQ(history.exit_code, 0) << history.output;
  const std::string table = ReadFileBytes(dir + "/history/history.html");
  EXPECT_NE(table.find("mAP@10cm"), std::string::npos);
  EXPECT_GT(ReadFileBytes(dir + "/history/history_0.png").size(), 1000u);

  // A run's options file gives the same run again; unknown keys are refused.
  testing::WriteText(dir + "/options.json",
                     "{\"relative_threshold\": 0.15, \"fit\": {\"iterations\": 600}}");
  const testing::CommandResult again = Workbench("evaluate --quiet --split all --options " + dir +
                                                 "/options.json --model " + model + " --db " + db);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(Workbench("regress --db " + db + " --run 3 --baseline 1 --tolerance 0").exit_code, 0);
  testing::WriteText(dir + "/typo.json", "{\"relative_treshold\": 0.2}");
  const testing::CommandResult typo = Workbench("evaluate --quiet --options " + dir +
                                                "/typo.json --model " + model + " --db " + db);
  EXPECT_EQ(typo.exit_code, 1);
  EXPECT_NE(typo.output.find("unknown detector option 'relative_treshold'"), std::string::npos)
      << typo.output;
  testing::WriteText(dir + "/range.json", "{\"min_score\": 3}");
  EXPECT_NE(Workbench("evaluate --quiet --options " + dir + "/range.json --model " + model +
                      " --db " + db)
                .output.find("min score must be in 0..1"),
            std::string::npos);

  // Bad baselines and runs: one line, exit 1.
  testing::WriteText(dir + "/bad.json", "{\"not\": \"metrics\"}");
  const testing::CommandResult bad =
      Workbench("regress --db " + db + " --baseline " + dir + "/bad.json");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.output.find("not a baseline file"), std::string::npos) << bad.output;
  EXPECT_EQ(Workbench("regress --db " + db + " --run 99 --baseline 1").exit_code, 1);
  EXPECT_NE(Workbench("evaluate --model " + model + " --db " + db + " --split nope")
                .output.find("must be train, val, test or all"),
            std::string::npos);
}

}  // namespace
}  // namespace furn
