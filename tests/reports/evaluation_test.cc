// Protocols A and B on hand-made frames whose answers are known.
#include <gtest/gtest.h>

#include <cmath>

#include "reports/evaluation.h"
#include "tests/test_util.h"

namespace furn {
namespace {

TruthObject Chair(double x, double y, double visibility = 1.0, bool seen = true) {
  TruthObject t;
  t.furniture_class = FurnitureClass::kChair;
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
  d.furniture_class = FurnitureClass::kChair;
  d.model_id = model;
  d.x = x;
  d.y = y;
  d.score = score;
  return d;
}

EvaluationOptions ChairsOnly() {
  EvaluationOptions options;
  options.classes = {FurnitureClass::kChair};
  return options;
}

HoughMaximum Maximum(const std::string& furniture_class,
                     double x,
                     double y,
                     HypothesisOutcome outcome) {
  HoughMaximum h;
  h.furniture_class = ParseFurnitureClass(furniture_class);
  h.x = x;
  h.y = y;
  h.outcome = outcome;
  return h;
}

// Each object lost at a known stage, and each kind of false positive.
TEST(Funnel, EachObjectIsCountedAtTheStageThatLostIt) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0),  // found
                 Chair(2, 0),  // a maximum rejected for coverage, one for score: score is further
                 Chair(4, 0),  // only a table maximum near it
                 Chair(6, 0),  // nothing near it
                 Chair(8, 0),  // its maximum's detection landed 30 cm away
                 Chair(10, 0, 0.1)};  // barely visible: ignored, not counted
  frame.maxima = {Maximum("chair", 0.02, 0, HypothesisOutcome::kDetected),
                  Maximum("chair", 2.05, 0, HypothesisOutcome::kLowCoverage),
                  Maximum("chair", 1.95, 0.05, HypothesisOutcome::kLowScore),
                  Maximum("table", 4.03, 0, HypothesisOutcome::kNoFit),
                  Maximum("chair", 6.4, 0, HypothesisOutcome::kNoFit),  // too far from it
                  Maximum("chair", 8.1, 0, HypothesisOutcome::kDetected)};
  frame.detections = {Found(0.02, 0, 0.9),   // TP
                      Found(0.07, 0, 0.8),   // duplicate
                      Found(8.3, 0, 0.7),    // mislocated
                      Found(10.02, 0, 0.6),  // on the ignored chair: not an FP
                      Found(20, 0, 0.5)};    // background
  TruthObject table;
  table.furniture_class = FurnitureClass::kTable;
  table.x = 30;
  table.visibility = 1;
  table.distance_m = 2;
  frame.truth.push_back(table);
  frame.detections.push_back(Found(30.1, 0, 0.4));  // wrong class
  const EvaluationResult r = EvaluateFrames({frame}, ChairsOnly());
  const auto& m = r.metrics;
  EXPECT_EQ(m.at("funnel/chair/detected"), 1);
  EXPECT_EQ(m.at("funnel/chair/low_score"), 1);
  EXPECT_EQ(m.at("funnel/chair/wrong_class_only"), 1);
  EXPECT_EQ(m.at("funnel/chair/no_maximum"), 1);
  EXPECT_EQ(m.at("funnel/chair/detected_off_target"), 1);
  EXPECT_FALSE(m.count("funnel/chair/low_coverage"));
  double counted = 0;
  for (FunnelStage stage : EnumValues<FunnelStage>())
    counted += m.at(std::string("funnel/all/") + EnumName(stage));
  EXPECT_EQ(counted, 5);  // every target once; the ignored chair not at all
  EXPECT_EQ(m.at("false_positives/duplicate"), 1);
  EXPECT_EQ(m.at("false_positives/mislocated"), 1);
  EXPECT_EQ(m.at("false_positives/background"), 1);
  EXPECT_EQ(m.at("false_positives/wrong_class"), 1);
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

OrientedBox Cube(double x, double y, double side, double yaw = 0) {
  OrientedBox box;
  box.centre = Eigen::Vector3d(x, y, side / 2);
  box.size = Eigen::Vector3d(side, side, side);
  box.yaw = yaw;
  return box;
}

// The box metrics (AP at 3-D and bird's-eye IoU, the SUN RGB-D / ScanNet
// protocol as mmdetection3d computes it): 1 m cubes; a detection shifted by
// 0.4 m along x overlaps 0.6 / 1.4 = 0.43 (a TP at 0.25, an FP at 0.5); a
// second detection of a taken object is an FP even where it overlaps; a
// detection overlapping nothing enough is an FP.
TEST(ProtocolIou, GreedyByScoreOnTheBestOverlappingObject) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0), Chair(3, 0)};
  frame.truth[0].box3d = Cube(0, 0, 1);
  frame.truth[1].box3d = Cube(3, 0, 1);
  frame.detections = {Found(0, 0, 0.9), Found(0.1, 0, 0.8), Found(3.4, 0, 0.7), Found(6, 0, 0.6)};
  frame.detections[0].box3d = Cube(0, 0, 1, 0.0);  // IoU 1
  frame.detections[1].box3d = Cube(0.1, 0, 1);     // the same object again: FP
  frame.detections[2].box3d = Cube(3.4, 0, 1);     // IoU 0.6 / 1.4
  frame.detections[3].box3d = Cube(6, 0, 1);       // nothing
  const EvaluationResult r = EvaluateFrames({frame}, ChairsOnly());
  // @0.25: TP, FP, TP, FP -> recall 1/2 at precision 1, 1 at 2/3.
  EXPECT_NEAR(r.metrics.at("AP3D/chair@0.25"), 0.5 + 0.5 * 2.0 / 3, 1e-12);
  EXPECT_NEAR(r.metrics.at("mAP3D@0.25"), 0.5 + 0.5 * 2.0 / 3, 1e-12);
  // @0.5: only the first.
  EXPECT_NEAR(r.metrics.at("AP3D/chair@0.50"), 0.5, 1e-12);
  // Footprints of equal height: the bird's-eye figures are the same here.
  EXPECT_NEAR(r.metrics.at("APBEV/chair@0.25"), r.metrics.at("AP3D/chair@0.25"), 1e-12);
  // A box twice as tall as its object: BEV IoU 1, 3-D IoU 0.5.
  frame.detections = {Found(0, 0, 0.9)};
  frame.detections[0].box3d = Cube(0, 0, 1);
  frame.detections[0].box3d.size.z() = 2;
  frame.detections[0].box3d.centre.z() = 1;
  const EvaluationResult tall = EvaluateFrames({frame}, ChairsOnly());
  EXPECT_NEAR(tall.metrics.at("APBEV/chair@0.50"), 0.5, 1e-12);  // one of two objects
  EXPECT_NEAR(tall.metrics.at("AP3D/chair@0.50"), 0.5, 1e-12);   // IoU exactly 0.5
  frame.detections[0].box3d.size.z() = 2.2;
  frame.detections[0].box3d.centre.z() = 1.1;
  EXPECT_NEAR(EvaluateFrames({frame}, ChairsOnly()).metrics.at("AP3D/chair@0.50"), 0, 1e-12);
  // Without 3-D boxes (a set labelled without heights): no box metric at all.
  frame.truth[1].box3d = OrientedBox{};
  EXPECT_EQ(EvaluateFrames({frame}, ChairsOnly()).metrics.count("AP3D/chair@0.25"), 0u);
}

// The confusion counts what detect outputs, each object to find once:
// detections below the operating point are not in it, a true object nothing
// reached is "missed", a second detection of an object or one on an
// ignored object is left out (counted apart), so a row adds up to its
// objects (issue 73: the chair row read 9 + 2 against 9 chairs).
TEST(Confusion, EachObjectOnceAgainstTheKeptDetections) {
  FrameOutcome frame;
  TruthObject table = Chair(3, 0);
  table.furniture_class = FurnitureClass::kTable;
  frame.truth = {Chair(0, 0), Chair(1, 0), table, Chair(5, 0, /*visibility=*/0.1)};
  ScoredDetection as_chair = Found(3.02, 0, 0.9);  // the table called a chair
  frame.detections = {Found(0.03, 0, 0.8),         // a hit
                      Found(0.05, 0, 0.6),         // a duplicate of it: left out
                      Found(1.0, 0, 0.2),          // below the chair's least score: not output
                      as_chair,
                      Found(5.01, 0, 0.9),  // on the barely visible chair (ignored): left out
                      Found(9, 0, 0.7)};    // nothing there
  EvaluationOptions options;
  options.operating_point.classes[static_cast<size_t>(FurnitureClass::kChair)].min_score = 0.5;
  const EvaluationResult r = EvaluateFrames({frame}, options);
  const auto named = ConfusionByName(r);
  EXPECT_EQ(named.at("chair").at("chair"), 1);
  EXPECT_EQ(named.at("chair").at("table"), 1);
  EXPECT_EQ(named.at("chair").at("background"), 1);
  EXPECT_EQ(named.at("missed").at("chair"), 1);      // the chair at x = 1
  EXPECT_EQ(named.at("missed").count("table"), 0u);  // reached, by the wrong class
  EXPECT_EQ(named.at("chair").size(), 3u);           // nothing else: 0.2 not kept
  EXPECT_EQ(r.confusion_extra, 2);                   // the duplicate, the ignored chair's
  int missed = 0;
  for (const auto& [c, n] : r.missed) missed += n;
  EXPECT_EQ(missed, 1);  // the barely visible chair is no target
  // The chair row (objects): found 1 + missed 1 = the 2 chairs to find.
  EXPECT_EQ(named.at("chair").at("chair") + named.at("missed").at("chair"), 2);
  // The frame's errors, as the report's gallery ranks frames: what detect
  // outputs gets wrong (the chair at x = 1 is found only below the operating
  // point, so it is missed; the table too; the duplicate is a false one).
  EXPECT_EQ(r.frame_errors.at(0), std::make_pair(3, 2));
}

// The centre error of the objects seen well: per object its nearest
// detection of its class, whatever its score; a miss counts as the reach, so
// the median reads it once half are missed.
TEST(CentreError, MedianOverObjectsSeenWellWithMissesAtTheReach) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0),
                 Chair(2, 0),
                 Chair(4, 0),
                 Chair(6, 0),
                 Chair(8, 0, /*visibility=*/0.3),  // a target, but seen too little
                 Chair(10, 0)};                    // all its pixels seen, but 40 % in view
  frame.truth.back().in_view = 0.4;
  frame.detections = {Found(0.02, 0, 0.3),  // 2 cm from the first: the weaker of two
                      Found(0.2, 0, 0.9),
                      Found(2.06, 0, 0.8),   // 6 cm
                      Found(4.3, 0, 0.1),    // 30 cm: weak, but a detection
                      Found(6.14, 0, 0.7),   // 14 cm
                      Found(8.01, 0, 0.9),   // on the little-seen chair: not counted
                      Found(10.4, 0, 0.9)};  // nor on the one mostly out of view
  const EvaluationOptions options = ChairsOnly();
  const MetricId id = MetricId::CentreErrorMedian(FurnitureClass::kChair);
  // 0.02, 0.06, 0.30, 0.14: the median of four.
  EXPECT_NEAR(EvaluateFrames({frame}, options).metrics.at(id.Name()), (0.06 + 0.14) / 2, 1e-9);
  // Without the 30 cm one, that chair is missed (the reach, 0.5 m); without
  // the 6 cm one too, half are missed and the median is the reach's mean
  // with 14 cm; with one more miss it reads the reach.
  frame.detections.erase(frame.detections.begin() + 3);
  EXPECT_NEAR(EvaluateFrames({frame}, options).metrics.at(id.Name()), (0.06 + 0.14) / 2, 1e-9);
  frame.detections.erase(frame.detections.begin() + 2);
  EXPECT_NEAR(EvaluateFrames({frame}, options).metrics.at(id.Name()), (0.14 + 0.5) / 2, 1e-9);
  frame.detections.erase(frame.detections.begin() + 2);
  EXPECT_NEAR(EvaluateFrames({frame}, options).metrics.at(id.Name()), kCentreErrorReachM, 1e-9);
  // A class without objects seen well has no such metric.
  EXPECT_FALSE(EvaluateFrames({frame}, options).metrics.count("centre/table/median_m"));
}

// --min-in-view: an object mostly beyond the image's side is neither found
// nor missed (a detection on it is no false positive); by default it counts.
TEST(ProtocolB, ObjectsMostlyOutOfViewAreIgnoredOnRequest) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0), Chair(2, 0), Chair(4, 0)};
  frame.truth[1].in_view = 0.3;
  frame.truth[2].in_view = 0.3;
  frame.detections = {Found(0.01, 0, 0.9), Found(2.01, 0, 0.8)};  // the third never found
  EvaluationOptions options = ChairsOnly();
  EvaluationResult r = EvaluateFrames({frame}, options);
  EXPECT_DOUBLE_EQ(r.metrics.at("objects"), 3);
  EXPECT_NEAR(r.metrics.at("AP/chair@10cm"), 2.0 / 3, 1e-12);
  options.min_in_view = 0.5;
  r = EvaluateFrames({frame}, options);
  EXPECT_DOUBLE_EQ(r.metrics.at("objects"), 1);
  EXPECT_NEAR(r.metrics.at("AP/chair@10cm"), 1.0, 1e-12);
  EXPECT_EQ(r.metrics.at("false_positives/background"), 0);
}

TEST(Calibration, BinsCountTruePositivesAndTheErrorWeighsThem) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0), Chair(2, 0), Chair(4, 0, /*visibility=*/0.1)};
  // 0.95: a TP; 0.91: a duplicate (FP); 0.35: a TP; 0.32: background (FP);
  // 0.5: on the barely visible chair, matched to an "ignore": left out.
  frame.detections = {Found(0, 0, 0.95),
                      Found(0.02, 0, 0.91),
                      Found(2, 0, 0.35),
                      Found(9, 9, 0.32),
                      Found(4, 0, 0.5)};
  const EvaluationResult r = EvaluateFrames({frame}, ChairsOnly());
  ASSERT_EQ(r.calibration.size(), 10u);
  EXPECT_EQ(r.calibration[9].detections, 2);
  EXPECT_EQ(r.calibration[9].true_positives, 1);
  EXPECT_NEAR(r.calibration[9].score_sum, 1.86, 1e-12);
  EXPECT_EQ(r.calibration[3].detections, 2);
  EXPECT_EQ(r.calibration[3].true_positives, 1);
  EXPECT_EQ(r.calibration[5].detections, 0);
  // (|1 - 1.86| + |1 - 0.67|) / 4
  EXPECT_NEAR(r.metrics.at("calibration_error"), (0.86 + 0.33) / 4, 1e-12);
  EXPECT_TRUE(std::isnan(CalibrationError({})));
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
  frame.maxima = {{FurnitureClass::kChair, 0.03, -0.02, 0.9},
                  {FurnitureClass::kChair, 1.0, 1.0, 0.5},
                  {FurnitureClass::kChair, 2.0, 0.1, 0.95}};
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

TEST(MetricId, NamesParseBackWithTheirDirectionAndUnit) {
  const std::vector<MetricId> ids = {
      MetricId::MeanAp(0.10),
      MetricId::ClassAp(FurnitureClass::kSofa, 0.05),
      MetricId::PaperBestF1(FurnitureClass::kTable),
      MetricId::StageLatency(DetectionStage::kFitAndVerify),
      MetricId::Funnel(FurnitureClass::kChair, FunnelStage::kNoMaximum),
      MetricId::Funnel(std::nullopt, FunnelStage::kDetected),
      MetricId::FalsePositives(FalsePositiveKind::kWrongClass),
      MetricId::Plain(PlainMetric::kFalseAboveTrue),
      MetricId::MeanAp(0.20).InGroup(MetricId::Group::kSpread),
      MetricId::Operating(std::nullopt, OperatingMeasure::kPrecision, 0.20),
      MetricId::Operating(FurnitureClass::kTable, OperatingMeasure::kFalsePerFrame, 0.10),
      MetricId::ClassAp(FurnitureClass::kChair, 0.10).InGroup(MetricId::Group::kGates),
      MetricId::CentreErrorMedian(FurnitureClass::kTable),
      MetricId::IouAp(FurnitureClass::kChair, 0.25, false),
      MetricId::IouAp(std::nullopt, 0.5, true)};
  const std::vector<std::string> names = {"mAP@10cm",
                                          "AP/sofa@5cm",
                                          "paper/table/best_f1",
                                          "latency_fit+verify_p50_ms",
                                          "funnel/chair/no_maximum",
                                          "funnel/all/detected",
                                          "false_positives/wrong_class",
                                          "false_above_true_error@20cm",
                                          "spread/mAP@20cm",
                                          "op/precision@20cm",
                                          "op/table/false_per_frame@10cm",
                                          "gates/AP/chair@10cm",
                                          "centre/table/median_m",
                                          "AP3D/chair@0.25",
                                          "mAPBEV@0.50"};
  for (size_t k = 0; k < ids.size(); ++k) {
    EXPECT_EQ(ids[k].Name(), names[k]);
    EXPECT_EQ(MetricId::Parse(names[k]).Name(), names[k]);
  }
  EXPECT_TRUE(MetricId::Parse("mAP@10cm").HigherIsBetter());
  EXPECT_FALSE(MetricId::Parse("false_above_true_error@20cm").HigherIsBetter());
  EXPECT_FALSE(MetricId::Parse("latency_vote_p50_ms").HigherIsBetter());
  EXPECT_STREQ(MetricId::Parse("latency_vote_p50_ms").Unit(), "ms");
  EXPECT_STREQ(MetricId::Parse("xy_error_mean_m").Unit(), "m");
  EXPECT_STREQ(MetricId::Parse("objects").Unit(), "count");
  EXPECT_STREQ(MetricId::Parse("centre/table/median_m").Unit(), "m");
  EXPECT_FALSE(MetricId::Parse("centre/table/median_m").HigherIsBetter());
  // A misspelt name is an error, not a silent NaN.
  EXPECT_TRUE(MetricId::Parse("op/chair/recall@20cm").HigherIsBetter());
  EXPECT_FALSE(MetricId::Parse("op/false_per_frame@20cm").HigherIsBetter());
  for (const char* bad : {"mAP@10",
                          "map@10cm",
                          "AP/stool@10cm",
                          "latency_nap_p50_ms",
                          "",
                          "op/stool/recall@20cm",
                          "op/chair/recal@20cm",
                          "centre/stool/median_m",
                          "centre/table/mean_m",
                          "op/precision",
                          "AP3D/chair@0.2",
                          "AP3D/stool@0.25",
                          "mAP3D@1.50",
                          "APXY/chair@0.25"})
    EXPECT_NE(testing::ErrorOf([&] { MetricId::Parse(bad); }).find("unknown metric"),
              std::string::npos)
        << bad;
}

// Ten chairs; detections scored 0.9 .. 0.1, the true ones the strongest
// but one: the best F1 keeps the detections down to the last true one, and
// the op/ metrics count what that threshold keeps.
TEST(OperatingPoint, BestF1ThresholdPerClassAndItsMetrics) {
  FrameOutcome frame;
  for (int k = 0; k < 10; ++k) frame.truth.push_back(Chair(k, 0));
  // True: 0.9, 0.8, 0.6, 0.5, 0.4; false: 0.7 (background), 0.3, 0.2, 0.1.
  frame.detections = {Found(0, 0, 0.9),
                      Found(1, 0, 0.8),
                      Found(50, 0, 0.7),
                      Found(2, 0.05, 0.6),
                      Found(3, 0, 0.5),
                      Found(4, 0, 0.4),
                      Found(60, 0, 0.3),
                      Found(70, 0, 0.2),
                      Found(80, 0, 0.1)};
  const OperatingPoint point = ChooseOperatingPoint({frame}, ChairsOnly(), 0.2, "ten chairs");
  const ClassOperatingPoint& chair = point.classes[0];
  EXPECT_EQ(point.chosen_on, "ten chairs");
  EXPECT_EQ(chair.targets, 10);
  EXPECT_DOUBLE_EQ(chair.min_score, 0.4);  // 5 of 6 kept are true: F1 2*(5/6)(1/2)/(5/6+1/2)
  EXPECT_NEAR(chair.precision, 5.0 / 6, 1e-12);
  EXPECT_NEAR(chair.recall, 0.5, 1e-12);
  EXPECT_NEAR(chair.f1, 0.625, 1e-12);
  EXPECT_LT(point.classes[2].min_score, 0);  // no table to choose one on
  EXPECT_FALSE(point.Empty());
  EXPECT_TRUE(point.Keeps(FurnitureClass::kChair, 0.4));
  EXPECT_FALSE(point.Keeps(FurnitureClass::kChair, 0.39));
  EXPECT_TRUE(point.Keeps(FurnitureClass::kTable, 0.01));

  EvaluationOptions options = ChairsOnly();
  options.operating_point = point;
  const auto m = EvaluateFrames({frame}, options).metrics;
  const auto op = [&](std::optional<FurnitureClass> c, OperatingMeasure measure) {
    return MetricOrNan(m, MetricId::Operating(c, measure, 0.2));
  };
  EXPECT_NEAR(op(FurnitureClass::kChair, OperatingMeasure::kPrecision), 5.0 / 6, 1e-12);
  EXPECT_NEAR(op(std::nullopt, OperatingMeasure::kRecall), 0.5, 1e-12);
  EXPECT_NEAR(op(std::nullopt, OperatingMeasure::kF1), 0.625, 1e-12);
  EXPECT_NEAR(op(std::nullopt, OperatingMeasure::kFalsePerFrame), 1.0, 1e-12);
  // Without an operating point the metrics describe every detection.
  const auto every = EvaluateFrames({frame}, ChairsOnly()).metrics;
  EXPECT_NEAR(
      MetricOrNan(every, MetricId::Operating(std::nullopt, OperatingMeasure::kPrecision, 0.2)),
      5.0 / 9,
      1e-12);
  EXPECT_NEAR(
      MetricOrNan(every, MetricId::Operating(std::nullopt, OperatingMeasure::kFalsePerFrame, 0.2)),
      4.0,
      1e-12);
  // AP does not depend on the operating point: it sweeps every detection.
  EXPECT_EQ(m.at("AP/chair@10cm"), every.at("AP/chair@10cm"));
}

// A class with too few objects of its own takes the threshold of every
// class's detections pooled, measured on its own objects.
TEST(OperatingPoint, AClassWithFewObjectsTakesThePooledThreshold) {
  FrameOutcome frame;
  for (int k = 0; k < 10; ++k) frame.truth.push_back(Chair(k, 0));
  frame.detections = {Found(0, 0, 0.9),
                      Found(1, 0, 0.8),
                      Found(50, 0, 0.7),
                      Found(2, 0, 0.6),
                      Found(3, 0, 0.5),
                      Found(4, 0, 0.4),
                      Found(60, 0, 0.3)};
  TruthObject table = Chair(100, 0);
  table.furniture_class = FurnitureClass::kTable;
  frame.truth.push_back(table);
  for (const auto& [x, score] : {std::pair{100.0, 0.45}, std::pair{200.0, 0.42}}) {
    frame.detections.push_back(Found(x, 0, score));
    frame.detections.back().furniture_class = FurnitureClass::kTable;
  }
  EvaluationOptions options;
  options.classes = {FurnitureClass::kChair, FurnitureClass::kTable};
  const OperatingPoint point = ChooseOperatingPoint({frame}, options, 0.2, "");
  // Pooled: 0.9 .. 0.4 keeps 6 true and 2 false of 11 objects (F1 0.63),
  // the best; the chairs (10 objects) choose 0.4 on their own as well.
  EXPECT_DOUBLE_EQ(point.classes[0].min_score, 0.4);
  const ClassOperatingPoint& t = point.classes[2];
  EXPECT_DOUBLE_EQ(t.min_score, 0.4);
  EXPECT_EQ(t.targets, 1);
  EXPECT_DOUBLE_EQ(t.precision, 0.5);  // the true table and the false one at 0.42
  EXPECT_DOUBLE_EQ(t.recall, 1.0);
  // Alone, the table's best F1 would keep only its 0.45 detection.
  options.classes = {FurnitureClass::kTable};
  EXPECT_DOUBLE_EQ(ChooseOperatingPoint({frame}, options, 0.2, "").classes[2].min_score, 0.45);
}

// A flat F1 curve: the highest threshold within 0.01 of the best F1 is
// chosen, not the best's own at the curve's low end.
TEST(OperatingPoint, TheHighestThresholdOnTheF1PlateauIsChosen) {
  FrameOutcome frame;
  for (int k = 0; k < 20; ++k) frame.truth.push_back(Chair(k, 0));
  for (int k = 0; k < 12; ++k) frame.detections.push_back(Found(k, 0, 0.95 - 0.01 * k));
  // 12 true of 12 at 0.84: F1 24/32 = 0.75. Three false, two true below:
  // 14 true, 3 false at 0.69: F1 28/37 = 0.757, the best by 0.007.
  for (const auto& [x, score] :
       {std::pair{50.0, 0.80}, {51.0, 0.79}, {52.0, 0.78}, {12.0, 0.70}, {13.0, 0.69}, {60.0, 0.5}})
    frame.detections.push_back(Found(x, 0, score));
  const ClassOperatingPoint chair = ChooseOperatingPoint({frame}, ChairsOnly(), 0.2, "").classes[0];
  EXPECT_NEAR(chair.min_score, 0.84, 1e-12);
  EXPECT_NEAR(chair.f1, 0.75, 1e-12);
  EXPECT_NEAR(chair.precision, 1.0, 1e-12);
  // A best F1 more than 0.01 above: chosen. One more true at 0.68 gives
  // 15 true, 3 false: F1 30/38 = 0.789.
  frame.detections.push_back(Found(14, 0, 0.68));
  EXPECT_DOUBLE_EQ(ChooseOperatingPoint({frame}, ChairsOnly(), 0.2, "").classes[0].min_score, 0.68);
}

// Equal scores go together: a threshold never splits detections of one score.
TEST(OperatingPoint, EqualScoresAreKeptOrDroppedTogether) {
  FrameOutcome frame;
  frame.truth = {Chair(0, 0), Chair(1, 0)};
  frame.detections = {Found(0, 0, 0.9), Found(1, 0, 0.5), Found(40, 0, 0.5), Found(41, 0, 0.5)};
  const OperatingPoint point = ChooseOperatingPoint({frame}, ChairsOnly(), 0.2, "");
  // 0.9 alone: F1 2/3; with the three at 0.5: P 2/4, R 1, F1 2/3: the higher.
  EXPECT_DOUBLE_EQ(point.classes[0].min_score, 0.9);
  // A class whose objects were never found gets no threshold.
  frame.detections = {Found(40, 0, 0.5)};
  const OperatingPoint never = ChooseOperatingPoint({frame}, ChairsOnly(), 0.2, "");
  EXPECT_LT(never.classes[0].min_score, 0);
  EXPECT_EQ(never.classes[0].f1, 0);
}

TEST(MetricId, EveryOutcomeHasItsFunnelStage) {
  for (HypothesisOutcome outcome : EnumValues<HypothesisOutcome>()) {
    const FunnelStage stage = FunnelStageOf(outcome);
    if (outcome == HypothesisOutcome::kDetected) {
      EXPECT_EQ(stage, FunnelStage::kDetectedOffTarget);
    } else {
      EXPECT_STREQ(EnumName(stage), OutcomeName(outcome));
    }
  }
}

// Every metric an evaluation writes has an id: names are never typed by hand.
TEST(MetricId, EveryMetricOfAnEvaluationParses) {
  FrameOutcome frame;
  frame.frame_id = 1;
  frame.total_ms = 5;
  frame.stage_ms[DetectionStage::kVote] = 1;
  double x = 0;
  for (FurnitureClass c : kAllClasses) {
    x += 1;
    TruthObject t;
    t.furniture_class = c;
    t.model_id = ClassName(c);
    t.x = x;
    t.visibility = 1;
    frame.truth.push_back(t);
    frame.detections.push_back({{x, 0, 0}, c, ClassName(c), 0.9, 1});
  }
  const EvaluationResult result = EvaluateFrames({frame}, EvaluationOptions{});
  for (const auto& [name, value] : result.metrics)
    EXPECT_TRUE(MetricId::TryParse(name).has_value()) << name;
  EXPECT_EQ(result.metrics.at("AP/sofa@10cm"), 1.0);
  EXPECT_EQ(ConfusionByName(result).at("sofa").at("sofa"), 1);
}

}  // namespace
}  // namespace furn
