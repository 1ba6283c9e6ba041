// Report pieces whose words and shapes are known: history lines per split,
// confusion shapes, APs with their object counts.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "core/util/file_util.h"
#include "reports/confusion.h"
#include "reports/run_report.h"
#include "reports/training_curve.h"
#include "tests/test_util.h"

namespace furn {
namespace {

RunRecord MakeRun(int64_t id, Split split, const std::string& kind, const std::string& started) {
  RunRecord run;
  run.id = id;
  run.split = split;
  run.kind = kind;
  run.started = started;
  run.git_commit = "0123456789abcdef";
  return run;
}

// A tuning run on val and evaluations on test are separate lines: a change
// of split never reads as a regression.
TEST(History, RunsOnOtherSplitsAreOtherLines) {
  HistoryDataset synth;
  synth.name = "synth";
  synth.runs = {MakeRun(1, Split::kTest, "evaluate", "2026-01-01T00:00:00Z"),
                MakeRun(2, Split::kVal, "tune", "2026-01-02T00:00:00Z"),
                MakeRun(3, Split::kTest, "evaluate", "2026-01-03T00:00:00Z")};
  synth.metrics = {{{"mAP@10cm", 0.4}}, {{"mAP@10cm", 0.9}}, {{"mAP@10cm", 0.41}}};
  const std::string dir = testing::ScratchDir();
  WriteHistoryReport({synth}, dir);
  const std::string page = ReadFileBytes(dir + "/history.html");
  EXPECT_NE(page.find("<span class=\"series\">synth, test</span> (2 runs)"), std::string::npos)
      << page;
  EXPECT_NE(page.find("<span class=\"series\">synth, val (tune)</span> (1 runs)"),
            std::string::npos)
      << page;
  EXPECT_NE(page.find("<th>split</th>"), std::string::npos);
  EXPECT_NE(page.find("<td>synth</td><td>val</td><td>2</td>"), std::string::npos) << page;
  EXPECT_GT(ReadFileBytes(dir + "/history_0.png").size(), 1000u);
}

TEST(Confusion, RowsAndColumnsMayDifferButNotTheirCounts) {
  const std::string dir = testing::ScratchDir();
  const std::string png = dir + "/confusion.png";
  WriteConfusionPng({"chair", "table", "background"},
                    {"chair", "table", "missed"},
                    {{5, 1, 2}, {0, 3, 4}, {1, 0, 0}},
                    "at the operating point",
                    png);
  const cv::Mat image = cv::imread(png);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.rows, 70 + 3 * 70 + 20);
  const std::string error = testing::ErrorOf([&] {
    WriteConfusionPng({"chair"}, {"chair", "missed"}, {{1}}, "bad", dir + "/bad.png");
  });
  EXPECT_NE(error.find("needs 1 rows of 2 counts"), std::string::npos) << error;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.png"));
}

// Pixels of the charts' fourth colour (yellow, #ccbb44): the last weights'
// validation curve.
int YellowPixels(const cv::Mat& image) {
  int count = 0;
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      const cv::Vec3b bgr = image.at<cv::Vec3b>(r, c);
      count += std::abs(bgr[2] - 0xcc) < 24 && std::abs(bgr[1] - 0xbb) < 24 && bgr[0] < 0x70;
    }
  }
  return count;
}

// The training curve draws the last weights' validation mAP only where a
// weight average measured it.
TEST(TrainingCurve, LastWeightsAreACurveOfTheirOwn) {
  const std::string dir = testing::ScratchDir();
  std::vector<TrainingCurvePoint> points = {{1, 3.0, 2.5, 0.25}, {2, 2.0, 1.8, 0.40}};
  WriteTrainingCurvePng(points, "plain", dir + "/plain.png");
  points[0].last_weights_map = 0.20;
  points[1].last_weights_map = 0.38;
  WriteTrainingCurvePng(points, "averaged", dir + "/averaged.png");
  const cv::Mat plain = cv::imread(dir + "/plain.png"),
                averaged = cv::imread(dir + "/averaged.png");
  ASSERT_FALSE(plain.empty());
  ASSERT_FALSE(averaged.empty());
  EXPECT_EQ(YellowPixels(plain), 0);
  EXPECT_GT(YellowPixels(averaged), 100);
}

TEST(Tables, AnApCarriesTheObjectsItWasMeasuredOn) {
  EXPECT_EQ(ApWithObjects(0.8049, 95), "0.805 <small>(95)</small>");
  EXPECT_EQ(ApWithObjects(1.0, std::nan("")), "1.000");
}

}  // namespace
}  // namespace furn
