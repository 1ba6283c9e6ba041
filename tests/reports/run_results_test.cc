// The run's results record: one writer and one reader that give back what
// was written, byte for byte, and refuse a record someone else wrote wrongly
// in one line naming the run and the field.
#include "reports/run_results.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/test_util.h"

namespace furn {
namespace {

RunResults AnEvaluation() {
  RunResults results;
  results.curves["B/chair@10cm"] = {{0.5, 1.0, 0.9}, {1.0, 0.5, 0.1}};
  results.curves["A/table"] = {};
  results.calibration = {{0.0, 0.5, 4, 1, 1.0}, {0.5, 1.0, 2, 2, 1.5}};
  results.confusion["chair"]["chair"] = 3;
  results.confusion["missed"]["table"] = 1;
  results.frame_errors[12] = {1, 0};
  results.frame_errors[40] = {0, 2};
  return results;
}

TEST(RunResults, AnEvaluationReadsBackAsWritten) {
  const RunResults written = AnEvaluation();
  const RunResults read = RunResults::Parse(written.Json(), "run 1");
  EXPECT_EQ(read.kind, RunResults::Kind::kEvaluation);
  EXPECT_EQ(read.Json(), written.Json());
  ASSERT_EQ(read.curves.at("B/chair@10cm").size(), 2u);
  EXPECT_EQ(read.curves.at("B/chair@10cm")[1].precision, 0.5);
  EXPECT_EQ(read.calibration[1].true_positives, 2);
  EXPECT_EQ(read.confusion.at("missed").at("table"), 1);
  EXPECT_TRUE(read.confusion_has_missed);
  EXPECT_EQ(read.frame_errors.at(40), std::make_pair(0, 2));
}

TEST(RunResults, ACrossvalReadsBackAsWrittenNanIncluded) {
  RunResults written;
  written.kind = RunResults::Kind::kCrossval;
  written.calibration = {{0.0, 1.0, 3, 1, 0.9}};
  written.folds.push_back(
      {0, 7, {{"chair", 2}}, {{"mAP@10cm", 0.4}, {"AP/sofa@10cm", std::nan("")}}});
  written.folds.push_back({1, 8, {{"table", 1}}, {{"mAP@10cm", 0.6}}});
  const RunResults read = RunResults::Parse(written.Json(), "run 9");
  EXPECT_EQ(read.kind, RunResults::Kind::kCrossval);
  EXPECT_EQ(read.Json(), written.Json());
  ASSERT_EQ(read.folds.size(), 2u);
  EXPECT_EQ(read.folds[1].run, 8);
  EXPECT_EQ(read.folds[0].held_out.at("chair"), 2);
  EXPECT_TRUE(std::isnan(read.folds[0].metrics.at("AP/sofa@10cm")));
  EXPECT_TRUE(read.calibration_stored);
}

TEST(RunResults, AnOlderRunWithoutLayoutsOrBinsIsRead) {
  const RunResults read = RunResults::Parse(R"({"confusion": {"chair": {"chair": 2}}})", "run 2");
  EXPECT_FALSE(read.confusion_has_missed);
  EXPECT_FALSE(read.calibration_stored);
  EXPECT_EQ(read.confusion.at("chair").at("chair"), 2);
}

TEST(RunResults, WrongRecordsAreOneLineNamingTheRunAndField) {
  for (const auto& [json, field] : std::vector<std::pair<std::string, std::string>>{
           {"[1, 2]", "not a JSON object"},
           {"not json", "not a JSON object"},
           {R"({"curves": [1]})", "'curves'"},
           {R"({"curves": {"B/chair": [[1, 2]]}})", "curve 'B/chair'"},
           {R"({"calibration": [[1, 2, 3]]})", "calibration bin"},
           {R"({"confusion": {"chair": {"chair": 1.5}}})", "confusion count"},
           {R"({"frame_errors": {"x12": [1, 0]}})", "frame 'x12'"},
           {R"({"frame_errors": {"12": [1]}})", "frame 12"},
           {R"({"folds": [{"metrics": {"mAP": "high"}}]})", "fold metric mAP"},
           {R"({"folds": {"0": 1}})", "'folds'"}}) {
    const std::string error = testing::ErrorOf([&] { RunResults::Parse(json, "db.db: run 3"); });
    EXPECT_EQ(error.rfind("db.db: run 3: ", 0), 0u) << json << " -> " << error;
    EXPECT_NE(error.find(field), std::string::npos) << json << " -> " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace furn
