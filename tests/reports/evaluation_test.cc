// Protocols A and B on hand-made frames whose answers are known.
#include <gtest/gtest.h>

#include <cmath>

#include "reports/evaluation.h"

namespace furn {
namespace {

TruthObject Chair(double x, double y, double visibility = 1.0, bool seen = true) {
  TruthObject t;
  t.furniture_class = "chair";
  t.model_id = seen ? "chair-a" : "chair-new";
  t.x = x;
  t.y = y;
  t.visibility = visibility;
  t.distance_m = 2;
  t.seen_in_training = seen;
  return t;
}

ScoredDetection Found(double x, double y, double score, const std::string& model = "chair-a") {
  ScoredDetection d;
  d.furniture_class = "chair";
  d.model_id = model;
  d.x = x;
  d.y = y;
  d.score = score;
  return d;
}

EvaluationOptions ChairsOnly() {
  EvaluationOptions options;
  options.classes = {"chair"};
  return options;
}

TEST(AveragePrecision, AllPointInterpolation) {
  // TP, FP, TP over 2 objects: recall 0.5 at precision 1, then 1.0 at 2/3.
  const std::vector<PrPoint> curve = {{0.5, 1.0, 0.9}, {0.5, 0.5, 0.8}, {1.0, 2.0 / 3, 0.7}};
  EXPECT_NEAR(AveragePrecision(curve), 0.5 * 1.0 + 0.5 * 2.0 / 3, 1e-12);
  EXPECT_DOUBLE_EQ(AveragePrecision({}), 0.0);
}

TEST(ProtocolB, GreedyMatchingByScoreWithinTheDistance) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0), Chair(2, 0)};
  // Best score first: the 0.9 detection takes the first chair; the 0.8 one
  // lies 4 cm from it too but it is taken, so it is an FP; the third finds
  // the second chair 8 cm off (a TP at 10 and 20 cm, an FP at 5 cm).
  frame.detections = {Found(0.01, 0, 0.9), Found(0.04, 0, 0.8), Found(2.08, 0, 0.7)};
  frame.total_ms = 50;
  const EvaluationResult r = EvaluateFrames({frame}, ChairsOnly());
  EXPECT_NEAR(r.metrics.at("AP/chair@10cm"), 0.5 + 0.5 * 2.0 / 3, 1e-12);
  EXPECT_NEAR(r.metrics.at("AP/chair@5cm"), 0.5, 1e-12);
  EXPECT_NEAR(r.metrics.at("mAP@20cm"), 0.5 + 0.5 * 2.0 / 3, 1e-12);
  EXPECT_NEAR(r.metrics.at("xy_error_mean_m"), (0.01 + 0.08) / 2, 1e-12);
  EXPECT_DOUBLE_EQ(r.metrics.at("cad_identified"), 1.0);
  EXPECT_DOUBLE_EQ(r.metrics.at("objects"), 2);
  EXPECT_DOUBLE_EQ(r.metrics.at("latency_p50_ms"), 50);
}

TEST(ProtocolB, BarelyVisibleAndFarObjectsAreIgnored) {
  FrameOutcome frame;
  TruthObject far = Chair(3, 0);
  far.distance_m = 3.5;
  frame.truth = {Chair(0, 0), Chair(1, 0, /*visibility=*/0.1), far};
  // Finding an ignored object is not an FP; missing it is not an FN.
  frame.detections = {Found(0, 0, 0.9), Found(1, 0, 0.8)};
  const EvaluationResult r = EvaluateFrames({frame}, ChairsOnly());
  EXPECT_DOUBLE_EQ(r.metrics.at("AP/chair@10cm"), 1.0);
  EXPECT_DOUBLE_EQ(r.metrics.at("objects"), 1);
}

TEST(ProtocolB, SeenAndUnseenModelsAreScoredApart) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0, 1, /*seen=*/true), Chair(2, 0, 1, /*seen=*/false)};
  frame.detections = {Found(0, 0, 0.9)};  // only the seen one found
  const EvaluationResult r = EvaluateFrames({frame}, ChairsOnly());
  EXPECT_DOUBLE_EQ(r.metrics.at("mAP_seen@10cm"), 1.0);
  EXPECT_DOUBLE_EQ(r.metrics.at("mAP_unseen@10cm"), 0.0);
  EXPECT_DOUBLE_EQ(r.metrics.at("mAP@10cm"), 0.5);
}

TEST(ProtocolB, YawErrorIsTakenModuloTheModelSymmetry) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0)};
  frame.truth[0].yaw = 0.1;
  ScoredDetection d = Found(0, 0, 0.9);
  d.yaw = M_PI + 0.1 + 0.05;  // 180 degrees off, plus 0.05 rad
  d.symmetry = 2;
  frame.detections = {d};
  EXPECT_NEAR(EvaluateFrames({frame}, ChairsOnly()).metrics.at("yaw_error_mean_deg"),
              0.05 * 180 / M_PI,
              1e-9);
  frame.detections[0].symmetry = 1;
  EXPECT_NEAR(EvaluateFrames({frame}, ChairsOnly()).metrics.at("yaw_error_mean_deg"),
              180 - 0.05 * 180 / M_PI,
              1e-9);
}

TEST(ProtocolA, MaximaInTheWindowAreFoundAsTheThresholdRises) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0), Chair(2, 0)};
  frame.maxima = {{"chair", 0.03, -0.02, 0.9}, {"chair", 1.0, 1.0, 0.5}, {"chair", 2.0, 0.1, 0.95}};
  EvaluationOptions options = ChairsOnly();
  options.paper_thresholds = {0.0, 0.6, 0.92};
  const EvaluationResult r = EvaluateFrames({frame}, options);
  const std::vector<PrPoint>& curve = r.curves.at("A/chair");
  ASSERT_EQ(curve.size(), 3u);
  // t = 0: all three maxima; the one at (2, 0.1) is 10 cm off: outside the 5 cm window.
  EXPECT_DOUBLE_EQ(curve[0].recall, 0.5);
  EXPECT_NEAR(curve[0].precision, 1.0 / 3, 1e-12);
  EXPECT_DOUBLE_EQ(curve[1].precision, 0.5);  // t = 0.6 drops the one in free space
  EXPECT_DOUBLE_EQ(curve[2].recall, 0.0);     // t = 0.92 keeps only the 10 cm miss
  EXPECT_NEAR(r.metrics.at("paper/chair/best_f1"), 0.5, 1e-12);
}

TEST(Regressions, HigherOrLowerIsBetterByName) {
  EXPECT_TRUE(HigherIsBetter("mAP@10cm"));
  EXPECT_FALSE(HigherIsBetter("xy_error_mean_m"));
  EXPECT_FALSE(HigherIsBetter("latency_p50_ms"));
}

}  // namespace
}  // namespace furn
