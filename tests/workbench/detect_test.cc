// Detection end to end on rendered rooms: procedural furniture placed at
// known poses, a Kinect v1 frame from Embree and the sensor model, then the
// detector with a model trained on the same procedural catalog.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "core/detector/detector.h"
#include "core/geometry/mesh.h"  // ContentHasher
#include "core/geometry/scan_fusion.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "renderers/embree_caster.h"
#include "renderers/kinect_simulator.h"
#include "reports/detection_debug.h"
#include "scenes/room_composer.h"
#include "tests/test_util.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/detection_output.h"
#include "workbench/formats/point_cloud_file.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/train.h"

namespace furn {
namespace {

constexpr char kCatalog[] = "procedural:4";

// One model trained for the whole file (training takes a few seconds).
class DetectTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    Progress::SetQuiet(true);
    catalog_ = new Catalog(OpenCatalog(kCatalog));
    ScanOptions scan;
    scan.heights_m = {1.0, 1.5};
    scan.azimuths = 8;
    TrainerOptions trainer;
    trainer.vocabulary.words = 20;
    trainer.vocabulary.kind = VocabularyKind::kKMeans;
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / "furn_tests" / "DetectTest";
    std::filesystem::create_directories(dir);
    model_path_ = new std::string((dir / "model.fcm").string());
    TrainFromCatalog(*catalog_, scan, trainer, *model_path_);
    DetectorOptions options;
    options.max_range_m = 4;  // the far pieces stand 3 to 3.8 m from the camera
    detector_ = new Detector(LoadTrainedModel(*model_path_), options);
  }
  static void TearDownTestSuite() {
    delete detector_;
    delete model_path_;
    delete catalog_;
  }

  // The id of the k-th model of a class in the catalog.
  static std::string ModelOf(FurnitureClass furniture_class, int k) {
    int seen = 0;
    for (const CatalogEntry* entry : catalog_->Classified()) {
      if (*entry->furniture_class == furniture_class && seen++ == k) return entry->id;
    }
    throw InputError("no such model");
  }

  // One chair at (0.2, 0.1), turned 30 degrees, as a 640 x 480 depth image
  // (0: no return).
  static DepthFrame OneChairDepth() {
    const DetectionInput input = Render({{ModelOf(FurnitureClass::kChair, 1), 0.2, 0.1, 30}});
    DepthFrame frame;
    frame.Resize(640, 480);
    for (size_t i = 0; i < input.points.size(); ++i)
      frame.depth[i] = input.points[i].allFinite() ? input.points[i].z() : 0.0f;
    return frame;
  }

  struct Placement {
    std::string model_id;
    double x, y, yaw_deg;
    bool target = true;
  };

  // A 6 x 6 m room with the pieces, seen from (x, -2.6, 1.8) looking along
  // +y, pitched down 33 degrees (x = 0 unless given).
  static DetectionInput Render(const std::vector<Placement>& placements,
                               const std::vector<CadModel>& extra_meshes = {},
                               double camera_x = 0) {
    RoomLayout layout;
    layout.width_m = 6;
    layout.depth_m = 6;
    layout.wall_height_m = 2.5;
    std::map<std::string, std::shared_ptr<const TriangleMesh>> meshes;
    uint16_t instance = kFirstObjectId;
    for (const Placement& p : placements) {
      PlacedObject object;
      object.model_id = p.model_id;
      object.x = p.x;
      object.y = p.y;
      object.yaw = p.yaw_deg * M_PI / 180;
      object.instance_id = instance++;
      bool found = false;
      for (const CadModel& extra : extra_meshes) {
        if (extra.id == p.model_id) {
          meshes[p.model_id] = std::make_shared<TriangleMesh>(extra.mesh);
          found = true;
        }
      }
      if (!found) {
        LoadedModels loaded = catalog_->LoadModels({p.model_id}, false);
        loaded.RequireAll();
        object.furniture_class = catalog_->Get(p.model_id).furniture_class;
        meshes[p.model_id] = std::make_shared<TriangleMesh>(loaded.models[0].mesh);
      }
      layout.objects.push_back(object);
    }
    const Scene scene = BuildRoomScene(layout, meshes);
    const double pitch = 33 * M_PI / 180;
    const Eigen::Isometry3d world_from_camera =
        LookAlong(Eigen::Vector3d(camera_x, -2.6, 1.8),
                  Eigen::Vector3d(0, std::cos(pitch), -std::sin(pitch)));
    EmbreeCaster caster;
    const KinectCapture capture = CaptureKinect(
        &caster, scene, CameraIntrinsics::KinectV1(), world_from_camera, KinectNoiseOptions{}, 7);
    if (std::getenv("FURN_TEST_DEBUG_DIR") != nullptr) {  // how much of each piece is in view
      std::map<int, int> pixels;
      for (uint16_t id : capture.ideal.instance_ids) ++pixels[id];
      for (const PlacedObject& object : layout.objects)
        std::printf("%s: %d pixels\n", object.model_id.c_str(), pixels[object.instance_id]);
    }
    DetectionInput input;
    input.points = BackProject(capture.noisy, CameraIntrinsics::KinectV1());
    input.width = 640;
    input.height = 480;
    input.world_from_camera = world_from_camera;
    return input;
  }

  static double YawErrorDeg(double a, double b) {
    const double d = std::fmod(std::abs(a - b), 2 * M_PI);
    return std::min(d, 2 * M_PI - d) * 180 / M_PI;
  }

  // FURN_TEST_DEBUG_DIR=dir writes each test's debug PNGs there, to look at.
  static void MaybeWriteDebug(const DetectionResult& result,
                              const std::vector<Placement>& truth = {}) {
    if (const char* dir = std::getenv("FURN_TEST_DEBUG_DIR")) {
      const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
      std::vector<GroundTruthFootprint> footprints;
      for (const Placement& p : truth) {
        const CatalogEntry& entry = catalog_->Get(p.model_id);
        footprints.push_back(
            {{p.x, p.y, p.yaw_deg * M_PI / 180, entry.size_m.x(), entry.size_m.y()},
             entry.furniture_class,
             entry.size_m.z(),
             p.model_id,
             1.0});
      }
      WriteDetectionDebug(result,
                          detector_->model(),
                          CameraIntrinsics::KinectV1(),
                          footprints,
                          std::string(dir) + "/" + info->name());
    }
  }

  static std::string Describe(const DetectionResult& result) {
    MaybeWriteDebug(result);
    std::string text;
    for (const DetectionDebug::Hypothesis& h : result.debug.hypotheses) {
      char line[200];
      std::snprintf(line,
                    sizeof(line),
                    "\n hypothesis %s at (%.2f, %.2f) votes %.3f: %s",
                    ClassName(h.furniture_class),
                    h.x,
                    h.y,
                    h.vote_weight,
                    DetectionDebug::Describe(h).c_str());
      text += line;
      for (const auto& f : h.fits) {
        std::snprintf(line,
                      sizeof(line),
                      "\n   %s (%.2f, %.2f) yaw %.0f covered %.2f vs %.2f",
                      detector_->model().model_names[f.model_index].c_str(),
                      f.x,
                      f.y,
                      f.yaw * 180 / M_PI,
                      f.covered_fraction,
                      f.verification);
        text += line;
      }
    }
    for (const Detection& d : result.detections) text += "\n  " + DetectionLine(d);
    return text;
  }

  static Catalog* catalog_;
  static std::string* model_path_;
  static Detector* detector_;
};

Catalog* DetectTest::catalog_ = nullptr;
std::string* DetectTest::model_path_ = nullptr;
Detector* DetectTest::detector_ = nullptr;

TEST_F(DetectTest, OneChairIsFoundWithItsPoseClassAndModel) {
  const std::string chair = ModelOf(FurnitureClass::kChair, 1);
  const DetectionResult result = detector_->Detect(Render({{chair, 0.2, 0.1, 30}}), true);
  ASSERT_EQ(result.detections.size(), 1u) << Describe(result);
  const Detection& d = result.detections[0];
  EXPECT_EQ(d.furniture_class, FurnitureClass::kChair);
  EXPECT_LT(std::hypot(d.x - 0.2, d.y - 0.1), 0.05) << Describe(result);
  EXPECT_LT(YawErrorDeg(d.yaw, 30 * M_PI / 180), 10) << Describe(result);
  EXPECT_EQ(d.model_name, chair);
  EXPECT_DOUBLE_EQ(d.in_view, 1.0);  // wholly inside the image
}

// Each stage called alone, in order, on one chair: what it hands to the next
// is right on its own, and the stages together give what Detect gives.
TEST_F(DetectTest, EachStageAloneOnOneChair) {
  const std::string chair = ModelOf(FurnitureClass::kChair, 1);
  const DetectionInput input = Render({{chair, 0.2, 0.1, 30}});
  const Detector& detector = *detector_;

  const PreparedScan scan = detector.Prepare(input);
  ASSERT_EQ(scan.status, DetectionStatus::kDetected) << scan.message;
  EXPECT_GT(scan.view.segments.size(), 3u);
  EXPECT_EQ(scan.structure.size(), scan.view.cloud.size());
  ASSERT_TRUE(scan.occupancy.has_value());
  ASSERT_TRUE(scan.intrinsics.has_value()) << "an organised scan keeps its depth image";
  EXPECT_EQ(scan.depth.size(), 640u * 480u);
  // (The room's walls are beyond the range here; a chair point is never structure.)
  for (size_t i = 0; i < scan.view.cloud.size(); ++i) {
    const Eigen::Vector3f& p = scan.view.cloud.points[i];
    if (std::hypot(p.x() - 0.2, p.y() - 0.1) < 0.15 && p.z() > 0.1) {
      EXPECT_FALSE(scan.structure[i]) << "a chair point marked as wall";
    }
  }

  const VoteMaps votes = detector.Vote(scan);
  ASSERT_EQ(votes.grids.size(), kAllClasses.size());
  EXPECT_EQ(votes.grids[0].size(), static_cast<size_t>(votes.cols) * votes.rows);
  EXPECT_FALSE(votes.votes.empty());

  std::vector<DetectionDebug::VoteGrid> grids;
  std::vector<DetectionDebug::Hypothesis> hypotheses = detector.FindMaxima(votes, &grids, true);
  ASSERT_FALSE(hypotheses.empty());
  int near_chair = -1;
  for (size_t h = 0; h < hypotheses.size(); ++h) {
    if (near_chair < 0 && hypotheses[h].furniture_class == FurnitureClass::kChair &&
        std::hypot(hypotheses[h].x - 0.2, hypotheses[h].y - 0.1) < 0.15)
      near_chair = static_cast<int>(h);
  }
  ASSERT_GE(near_chair, 0) << "no chair maximum within 15 cm";

  detector.RankCandidates(scan, votes, &hypotheses);
  const DetectionDebug::Hypothesis& hypothesis = hypotheses[near_chair];
  ASSERT_FALSE(hypothesis.segments.empty());
  ASSERT_EQ(hypothesis.candidate_models.size(), 3u);  // top_models
  for (int m : hypothesis.candidate_models)
    EXPECT_EQ(detector.model().model_classes[m], FurnitureClass::kChair);

  const HypothesisFit fit = detector.FitHypothesis(scan, hypothesis, near_chair);
  ASSERT_TRUE(fit.best.has_value());
  EXPECT_LE(fit.region.fit_points.size(), kMaxFitPoints);
  EXPECT_EQ(fit.region.points.size(), fit.region.cloud_index.size());
  EXPECT_EQ(static_cast<int>(fit.tried.size()), fit.fits);
  EXPECT_LT(std::hypot(fit.best->fit.pose.x - 0.2, fit.best->fit.pose.y - 0.1), 0.05);
  EXPECT_LE(fit.second_score, fit.best->score);

  // Every (hypothesis, candidate) pair fitted on its own gives the same
  // fits, to the bit, as one hypothesis after another.
  std::vector<int> ranked;
  for (size_t h = 0; h < hypotheses.size(); ++h) {
    if (!hypotheses[h].candidate_models.empty()) ranked.push_back(static_cast<int>(h));
  }
  ASSERT_GE(ranked.size(), 1u);
  const std::vector<HypothesisFit> together = detector.FitHypotheses(scan, hypotheses, ranked);
  ASSERT_EQ(together.size(), ranked.size());
  for (size_t k = 0; k < ranked.size(); ++k) {
    const HypothesisFit alone = detector.FitHypothesis(scan, hypotheses[ranked[k]], ranked[k]);
    ASSERT_EQ(together[k].fits, alone.fits) << "hypothesis " << ranked[k];
    ASSERT_EQ(together[k].best.has_value(), alone.best.has_value());
    EXPECT_EQ(together[k].second_score, alone.second_score);
    EXPECT_EQ(together[k].region.cloud_index, alone.region.cloud_index);
    for (size_t t = 0; t < alone.tried.size(); ++t) {
      EXPECT_EQ(together[k].tried[t].model_index, alone.tried[t].model_index);
      EXPECT_EQ(together[k].tried[t].yaw, alone.tried[t].yaw);
      EXPECT_EQ(together[k].tried[t].score, alone.tried[t].score);
    }
    if (alone.best) {
      EXPECT_EQ(together[k].best->model, alone.best->model);
      EXPECT_EQ(together[k].best->fit.pose.x, alone.best->fit.pose.x);
      EXPECT_EQ(together[k].best->posed, alone.best->posed);
    }
  }

  const FitVerification verification = detector.VerifyFit(scan, fit);
  EXPECT_GE(verification.covered, 0.75);
  EXPECT_GE(verification.verification, 0.6);
  EXPECT_GE(verification.seen_through, 0);  // organised: render-and-compare ran
  EXPECT_LE(verification.seen_through, 0.3);
  EXPECT_TRUE(verification.scorer_gates);

  const HypothesisScore score = detector.ScoreHypothesis(scan, hypothesis, fit, verification);
  EXPECT_EQ(score.outcome, HypothesisOutcome::kDetected);
  ASSERT_TRUE(score.features.has_value());
  EXPECT_EQ(score.features->furniture_class, FurnitureClass::kChair);
  EXPECT_FLOAT_EQ(score.features->covered, static_cast<float>(verification.covered));
  EXPECT_FLOAT_EQ(score.features->seen_through, static_cast<float>(verification.seen_through));
  EXPECT_GT(score.features->observed_height, 0.5f);  // the chair's back
  EXPECT_GT(score.explained_points.size(), 50u);

  // The stages together, as Detect runs them, give Detect's detection.
  std::vector<FittedHypothesis> fits = detector.FitAndVerify(scan, &hypotheses);
  const std::vector<int> kept = detector.Suppress(scan, fits, &hypotheses);
  ASSERT_EQ(kept.size(), 1u) << Describe(detector.Detect(input, true));
  const DetectionResult whole = detector.Detect(input);
  ASSERT_EQ(whole.detections.size(), 1u);
  EXPECT_EQ(fits[kept[0]].detection->x, whole.detections[0].x);
  EXPECT_EQ(fits[kept[0]].detection->yaw, whole.detections[0].yaw);
  EXPECT_EQ(fits[kept[0]].detection->model_name, whole.detections[0].model_name);
  // Detect's timings name every stage of the codebook path, in order, then
  // the total (the learned path's bev and network stages are not run).
  std::vector<DetectionStage> stages, expected;
  for (const StageTime& t : whole.timings_ms.stages) stages.push_back(t.stage);
  for (DetectionStage stage : EnumValues<DetectionStage>()) {
    if (stage != DetectionStage::kBev && stage != DetectionStage::kNetwork)
      expected.push_back(stage);
  }
  EXPECT_EQ(stages, expected);
}

TEST_F(DetectTest, TwoTablesAndFourChairsAreAllFoundAndNothingElse) {
  const std::string square_table = ModelOf(FurnitureClass::kTable, 1);
  const std::string long_table = ModelOf(FurnitureClass::kTable, 3);
  // Everything in view and within range; chairs around and between the tables.
  const std::vector<Placement> truth = {{square_table, -0.55, 0.35, 0},
                                        {long_table, 0.75, 0.3, 90},
                                        {ModelOf(FurnitureClass::kChair, 0), -0.55, -0.4, 180},
                                        {ModelOf(FurnitureClass::kChair, 2), -1.25, 0.35, 90},
                                        {ModelOf(FurnitureClass::kChair, 1), 0.12, 0.45, 270},
                                        {ModelOf(FurnitureClass::kChair, 3), 0.75, -0.75, 180}};
  const DetectionResult result = detector_->Detect(Render(truth), true);
  std::vector<bool> matched(truth.size(), false);
  for (const Detection& d : result.detections) {
    bool any = false;
    for (size_t k = 0; k < truth.size(); ++k) {
      const FurnitureClass c = *catalog_->Get(truth[k].model_id).furniture_class;
      if (!matched[k] && c == d.furniture_class &&
          std::hypot(d.x - truth[k].x, d.y - truth[k].y) < 0.10) {
        matched[k] = any = true;
        break;
      }
    }
    EXPECT_TRUE(any) << "false positive " << ClassName(d.furniture_class) << " at " << d.x << ", "
                     << d.y << Describe(result);
  }
  for (size_t k = 0; k < truth.size(); ++k)
    EXPECT_TRUE(matched[k]) << truth[k].model_id << " at " << truth[k].x << ", " << truth[k].y
                            << " missed" << Describe(result);
  MaybeWriteDebug(result, truth);  // the README's picture (docs/images/detection_topdown.png)
}

TEST_F(DetectTest, EmptyRoomAndClutterGiveNothing) {
  EXPECT_TRUE(detector_->Detect(Render({})).detections.empty());
  CadModel box{"clutter/box",
               "box",
               "",
               "",
               MakeBox(Eigen::Vector3f(-0.25f, -0.2f, 0), Eigen::Vector3f(0.25f, 0.2f, 0.35f))};
  CadModel tall{
      "clutter/column", "column", "", "", MakeCylinder(Eigen::Vector3f::Zero(), 0.15f, 1.2f, 24)};
  const DetectionResult clutter = detector_->Detect(
      Render({{"clutter/box", 0.3, -0.3, 20, false}, {"clutter/column", -0.8, 0.4, 0, false}},
             {box, tall}),
      true);
  EXPECT_TRUE(clutter.detections.empty()) << Describe(clutter);
}

// A chair pushed under a desk, seen from behind as in an office: the desk top
// lies in the chair's box. Counting every point in the box, the chair's fit
// explains too little of it; counting only segments mostly inside the box
// (own_segment_share) the chair is found where it stands.
TEST_F(DetectTest, AChairUnderADeskIsFoundWhenOnlyItsOwnSegmentsCount) {
  TriangleMesh desk_mesh =
      MakeBox(Eigen::Vector3f(-0.8f, -0.4f, 0.71f), Eigen::Vector3f(0.8f, 0.4f, 0.75f));
  for (float x : {-0.76f, 0.72f}) {
    for (float y : {-0.36f, 0.32f}) {
      AppendMesh(MakeBox(Eigen::Vector3f(x, y, 0), Eigen::Vector3f(x + 0.04f, y + 0.04f, 0.71f)),
                 &desk_mesh);
    }
  }
  const CadModel desk{"clutter/desk", "desk", "", "", desk_mesh};
  const std::string chair = ModelOf(FurnitureClass::kChair, 1);
  const DetectionInput input =
      Render({{"clutter/desk", 0.1, 0.7, 0, false}, {chair, 0.1, 0.3, 180}}, {desk});
  auto chair_found = [&](const DetectionResult& result) {
    for (const Detection& d : result.detections) {
      if (d.furniture_class == FurnitureClass::kChair && std::hypot(d.x - 0.1, d.y - 0.3) < 0.1)
        return true;
    }
    return false;
  };
  auto best_chair_cover = [&](const DetectionResult& result) {
    double best = 0;
    for (const DetectionDebug::Hypothesis& h : result.debug.hypotheses) {
      for (const auto& f : h.fits) {
        if (h.furniture_class == FurnitureClass::kChair && std::hypot(f.x - 0.1, f.y - 0.3) < 0.1)
          best = std::max(best, f.covered_fraction);
      }
    }
    return best;
  };
  const DetectionResult every_point = detector_->Detect(input, true);
  DetectorOptions options = detector_->options();
  options.own_segment_share = 0.5;
  const Detector own_segments(detector_->model(), options);
  const DetectionResult own = own_segments.Detect(input, true);
  EXPECT_TRUE(chair_found(own)) << Describe(own);
  EXPECT_GT(best_chair_cover(own), best_chair_cover(every_point) + 0.05)
      << Describe(every_point) << Describe(own);
  EXPECT_FALSE(chair_found(every_point)) << Describe(every_point);
}

TEST(DetectorOptions, OwnSegmentShareOutsideZeroToOneIsRefused) {
  DetectorOptions options;
  options.own_segment_share = 1.5;
  try {
    options.Check();
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("own segment share"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace furn

namespace furn {
namespace {

TEST_F(DetectTest, BadScansAreClearErrors) {
  // Nothing in range is an outcome, not an error: no detections, and why.
  DetectionInput empty;
  const DetectionResult nothing = detector_->Detect(empty);
  EXPECT_EQ(nothing.status, DetectionStatus::kNoPointsInRange);
  EXPECT_NE(nothing.message.find("no finite point within"), std::string::npos) << nothing.message;
  EXPECT_TRUE(nothing.detections.empty());
  DetectionInput nans;
  nans.points.assign(640 * 480, Eigen::Vector3f::Constant(std::nanf("")));
  nans.width = 640;
  nans.height = 480;
  EXPECT_EQ(detector_->Detect(nans).status, DetectionStatus::kNoPointsInRange);
  DetectionInput far = nans;  // everything beyond the range
  const float beyond = static_cast<float>(detector_->options().max_range_m) + 0.5f;
  for (size_t i = 0; i < far.points.size(); i += 7) far.points[i] = {0.1f, 0.2f, beyond};
  EXPECT_EQ(detector_->Detect(far).status, DetectionStatus::kNoPointsInRange);
  DetectionInput wrong_size = nans;
  wrong_size.width = 320;
  EXPECT_NE(testing::ErrorOf([&] { detector_->Detect(wrong_size); }).find("is not 320x480"),
            std::string::npos);
  // Without a pose, a scan of a wall alone has no floor: a frame without
  // detections that says why (evaluate counts it; detect prints the line).
  DetectionInput wall;
  for (float x = -1; x <= 1; x += 0.01f) {
    for (float y = -0.8f; y <= 0.8f; y += 0.01f) wall.points.emplace_back(x, y, 2.0f);
  }
  const DetectionResult no_floor = detector_->Detect(wall);
  EXPECT_EQ(no_floor.status, DetectionStatus::kNoFloor);
  EXPECT_TRUE(no_floor.detections.empty());
  EXPECT_NE(no_floor.message.find("no floor found"), std::string::npos) << no_floor.message;
  EXPECT_NE(no_floor.message.find("world_from_camera"), std::string::npos) << no_floor.message;
}

TEST_F(DetectTest, BadFilesAndIntrinsicsAreClearErrors) {
  const std::string dir = testing::ScratchDir();
  ScanSource source;
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(source); }).find("exactly one of"), std::string::npos);
  // An 8-bit PNG is not a depth image.
  const std::string eight_bit = dir + "/grey.png";
  cv::imwrite(eight_bit, cv::Mat(480, 640, CV_8UC1, cv::Scalar(100)));
  source.depth_path = eight_bit;
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(source); }).find("16-bit"), std::string::npos);
  // Kinect intrinsics for an image of another size.
  DepthFrame small;
  small.Resize(320, 240);
  WriteDepthPng(small, dir + "/small.png");
  source.depth_path = dir + "/small.png";
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(source); }).find("kinect1 are for 640x480"),
            std::string::npos);
  source.intrinsics = "525,525,400,100";  // principal point outside the image
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(source); }).find("must lie in the image"),
            std::string::npos);
  source.intrinsics = "fx=525";
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(source); }).find("four numbers"), std::string::npos);
  // A cloud file that is not one.
  ScanSource cloud;
  cloud.cloud_path = dir + "/broken.pcd";
  testing::WriteText(cloud.cloud_path, "not a point cloud\n");
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(cloud); }).find("broken.pcd"), std::string::npos);
  cloud.cloud_path = dir + "/scan.xyz";
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(cloud); }).find(".pcd or .ply"), std::string::npos);
  // A depth image with no return at all: for one scan given by the user, an error line.
  DepthFrame blank;
  blank.Resize(640, 480);
  WriteDepthPng(blank, dir + "/blank.png");
  const testing::CommandResult nothing =
      testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " detect --quiet --model " +
                          *model_path_ + " --depth " + dir + "/blank.png");
  EXPECT_EQ(nothing.exit_code, 1) << nothing.output;
  EXPECT_NE(nothing.output.find("blank.png"), std::string::npos) << nothing.output;
  EXPECT_NE(nothing.output.find("no finite point within"), std::string::npos) << nothing.output;
  // A model file of another format version.
  std::string bytes = ReadFileBytes(*model_path_);
  bytes[8] = 1;
  testing::WriteText(dir + "/v1.fcm", bytes);
  EXPECT_NE(testing::ErrorOf([&] { LoadTrainedModel(dir + "/v1.fcm"); }).find("version 1"),
            std::string::npos);
}

TEST_F(DetectTest, CommandLineOnAPcdWritesJsonAndDebugPngs) {
  const std::string dir = testing::ScratchDir();
  // An organised PCD of one chair, camera frame, as a Kinect driver writes it.
  const DepthFrame frame = OneChairDepth();
  WriteOrganizedPcd(frame, CameraIntrinsics::KinectV1(), dir + "/scan.pcd");
  const testing::CommandResult run = testing::RunCommand(
      std::string(FURN_WORKBENCH_BINARY) + " detect --model " + *model_path_ + " --cloud " + dir +
      "/scan.pcd --out " + dir + "/det.json --debug-dir " + dir + "/debug --timings");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json json = nlohmann::json::parse(ReadFileBytes(dir + "/det.json"));
  EXPECT_TRUE(json["floor_estimated"].get<bool>());  // no pose given: found by RANSAC
  ASSERT_EQ(json["detections"].size(), 1u) << run.output;
  EXPECT_EQ(json["detections"][0]["class"], "chair");
  EXPECT_EQ(json["detections"][0]["in_view"].get<double>(), 1.0);
  EXPECT_NE(run.output.find("total"), std::string::npos);  // --timings
  for (const char* png : {"segments.png", "fitted.png", "topdown.png", "votes_chair.png"}) {
    const cv::Mat image = cv::imread(dir + "/debug/" + png);
    EXPECT_FALSE(image.empty()) << png;
  }
  // --out - pipes the JSON (the summary goes to standard error).
  const testing::CommandResult piped = testing::RunCommand(
      "bash -c 'cd " + dir + " && " + FURN_WORKBENCH_BINARY + " detect --model " + *model_path_ +
      " --cloud scan.pcd --out - 2>/dev/null'");
  ASSERT_EQ(piped.exit_code, 0) << piped.output;
  EXPECT_EQ(nlohmann::json::parse(piped.output)["detections"].size(), 1u) << piped.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/-"));
  // A mistake in the command: one line, exit code 1.
  const testing::CommandResult bad =
      testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " detect --model " + dir +
                          "/missing.fcm --cloud " + dir + "/scan.pcd");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.output.find("missing.fcm"), std::string::npos);
}

// The points of `input` moved into its (floor-aligned) world frame, as an
// ASCII PCD of double fields: organised (640 x 480) or not (finite points
// only), with a VIEWPOINT line when `viewpoint` is given.
std::string WorldPcd(const DetectionInput& input,
                     bool organised,
                     const std::optional<Eigen::Isometry3d>& viewpoint) {
  const Eigen::Isometry3d pose = *input.world_from_camera;
  std::ostringstream body;
  body.precision(9);
  int count = 0;
  for (const Eigen::Vector3f& p : input.points) {
    if (!p.allFinite()) {
      if (organised) {
        body << "nan nan nan\n";
        ++count;
      }
      continue;
    }
    const Eigen::Vector3d w = pose * p.cast<double>();
    body << w.x() << " " << w.y() << " " << w.z() << "\n";
    ++count;
  }
  std::ostringstream pcd;
  pcd << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\n"
      << "WIDTH " << (organised ? 640 : count) << "\nHEIGHT " << (organised ? 480 : 1) << "\n";
  if (viewpoint) {
    const Eigen::Quaterniond q(viewpoint->linear());
    pcd << "VIEWPOINT " << viewpoint->translation().x() << " " << viewpoint->translation().y()
        << " " << viewpoint->translation().z() << " " << q.w() << " " << q.x() << " " << q.y()
        << " " << q.z() << "\n";
  }
  pcd << "POINTS " << count << "\nDATA ascii\n" << body.str();
  return pcd.str();
}

TEST_F(DetectTest, WorldFrameAndFloorAlignedCloudsGiveTheCameraFrameDetections) {
  const std::string dir = testing::ScratchDir();
  const DetectionInput input = Render({{ModelOf(FurnitureClass::kChair, 1), 0.2, 0.1, 30}});
  const DetectionResult reference = detector_->Detect(input);
  ASSERT_EQ(reference.detections.size(), 1u);
  const Eigen::Isometry3d pose = *input.world_from_camera;
  // The chair stands at (0.2, 0.1) of the floor-aligned world.
  auto expect_same = [&](const LoadedScan& scan,
                         const Detection& expected,
                         double tolerance_m,
                         const std::string& what) {
    const DetectionResult result = detector_->Detect(scan.input);
    ASSERT_EQ(result.detections.size(), 1u) << what << Describe(result);
    EXPECT_EQ(result.detections[0].furniture_class, FurnitureClass::kChair) << what;
    EXPECT_LT(std::hypot(result.detections[0].x - expected.x, result.detections[0].y - expected.y),
              tolerance_m)
        << what;
  };
  Detection truth;
  truth.x = 0.2;
  truth.y = 0.1;

  // Organised and floor-aligned, no pose: the camera comes from the pixel grid.
  testing::WriteText(dir + "/organised.pcd", WorldPcd(input, true, std::nullopt));
  ScanSource source;
  source.cloud_path = dir + "/organised.pcd";
  source.floor_aligned = true;
  const LoadedScan organised = LoadScan(source);
  ASSERT_TRUE(organised.input.world_from_camera.has_value());
  EXPECT_LT((organised.input.world_from_camera->translation() - pose.translation()).norm(), 0.01);
  EXPECT_LT(
      Eigen::AngleAxisd(organised.input.world_from_camera->linear().transpose() * pose.linear())
          .angle(),
      0.01);
  EXPECT_EQ(organised.pose_source, "estimated from the organised cloud");
  expect_same(organised, truth, 0.05, "organised floor-aligned");

  // Unorganised with the sensor pose in VIEWPOINT.
  testing::WriteText(dir + "/viewpoint.pcd", WorldPcd(input, false, pose));
  source.cloud_path = dir + "/viewpoint.pcd";
  const LoadedScan viewpoint = LoadScan(source);
  EXPECT_EQ(viewpoint.pose_source, "the PCD VIEWPOINT");
  expect_same(viewpoint, truth, 0.05, "VIEWPOINT");

  // Unorganised without a pose: the sensor position is needed ...
  testing::WriteText(dir + "/bare.pcd", WorldPcd(input, false, std::nullopt));
  source.cloud_path = dir + "/bare.pcd";
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(source); }).find("--sensor"), std::string::npos);
  // ... and enough with it.
  std::ostringstream sensor;
  sensor << pose.translation().x() << "," << pose.translation().y() << ","
         << pose.translation().z();
  source.sensor = sensor.str();
  expect_same(LoadScan(source), truth, 0.05, "--sensor");

  // A world frame that is not floor-aligned: the pose brings the points to
  // the camera, and the floor is found as usual, as for the camera-frame scan.
  DetectionInput camera_frame = input;
  camera_frame.world_from_camera.reset();
  const DetectionResult estimated = detector_->Detect(camera_frame);
  ASSERT_EQ(estimated.detections.size(), 1u);
  source.sensor.clear();
  source.floor_aligned = false;
  std::ostringstream matrix;
  matrix.precision(12);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) matrix << pose.matrix()(r, c) << (r == 3 && c == 3 ? "" : ",");
  }
  source.world_from_camera = matrix.str();
  const LoadedScan world = LoadScan(source);
  EXPECT_FALSE(world.input.world_from_camera.has_value());
  expect_same(world, estimated.detections[0], 0.03, "--world-from-camera");
}

// Two posed scans of one room (issue 37): a chair out of the first camera's
// view is found in the two fused, where the second camera saw it, and in the
// world where it stands; the command line fuses world-frame clouds alike.
TEST_F(DetectTest, FusedScansFindWhatOneScanDoesNotSee) {
  const std::string chair = ModelOf(FurnitureClass::kChair, 1);
  const std::vector<Placement> room = {{chair, 0.2, 0.1, 30}, {chair, 2.0, -0.6, 200}};
  const DetectionInput first = Render(room), second = Render(room, {}, 2.0);
  auto chairs_near = [](const DetectionResult& result, double x, double y) {
    int n = 0;
    for (const Detection& d : result.detections)
      n += d.furniture_class == FurnitureClass::kChair && std::hypot(d.x - x, d.y - y) < 0.1;
    return n;
  };
  const DetectionResult alone = detector_->Detect(first);
  EXPECT_EQ(chairs_near(alone, 0.2, 0.1), 1) << Describe(alone);
  EXPECT_EQ(chairs_near(alone, 2.0, -0.6), 0) << Describe(alone);
  const DetectionInput fused = FuseScans({second, first}, 1);
  const DetectionResult both = detector_->Detect(fused);
  EXPECT_EQ(chairs_near(both, 0.2, 0.1), 1) << Describe(both);
  EXPECT_EQ(chairs_near(both, 2.0, -0.6), 1) << Describe(both);
  EXPECT_EQ(both.detections.size(), 2u) << Describe(both);

  // The command: world-frame clouds, each with its pose in VIEWPOINT.
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/second.pcd", WorldPcd(second, false, *second.world_from_camera));
  testing::WriteText(dir + "/first.pcd", WorldPcd(first, false, *first.world_from_camera));
  const std::string detect = std::string(FURN_WORKBENCH_BINARY) + " detect --model " +
                             *model_path_ + " --max-range 4 --quiet ";
  const testing::CommandResult run =
      testing::RunCommand(detect + dir + "/second.pcd " + dir +
                          "/first.pcd --floor-aligned --fuse --out " + dir + "/fused.json");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json json = nlohmann::json::parse(ReadFileBytes(dir + "/fused.json"));
  EXPECT_NE(json["input"].get<std::string>().find("2 scans fused"), std::string::npos);
  ASSERT_EQ(json["detections"].size(), 2u) << json.dump();
  for (const nlohmann::json& d : json["detections"]) EXPECT_EQ(d["class"], "chair");
  const testing::CommandResult registered = testing::RunCommand(
      detect + dir + "/second.pcd " + dir + "/first.pcd --floor-aligned --fuse --fuse-register " +
      "--out " + dir + "/registered.json");
  ASSERT_EQ(registered.exit_code, 0) << registered.output;
  EXPECT_EQ(nlohmann::json::parse(ReadFileBytes(dir + "/registered.json"))["detections"].size(),
            2u);
  const testing::CommandResult level = testing::RunCommand(
      detect + dir + "/second.pcd " + dir + "/first.pcd --floor-aligned --fuse --fuse-register " +
      "--fuse-planar --out " + dir + "/level.json");
  ASSERT_EQ(level.exit_code, 0) << level.output;
  EXPECT_EQ(nlohmann::json::parse(ReadFileBytes(dir + "/level.json"))["detections"].size(), 2u);
  // Bad uses: one line each, exit code 1, nothing written.
  auto refused = [&](const std::string& arguments, const std::string& expected) {
    const testing::CommandResult bad =
        testing::RunCommand(detect + arguments + " --out " + dir + "/bad.json");
    EXPECT_EQ(bad.exit_code, 1) << arguments << "\n" << bad.output;
    EXPECT_NE(bad.output.find(expected), std::string::npos) << bad.output;
    EXPECT_FALSE(std::filesystem::exists(dir + "/bad.json")) << arguments;
  };
  refused(dir + "/first.pcd --floor-aligned --fuse", "--fuse needs two or more scans");
  refused(dir + "/second.pcd " + dir + "/first.pcd --fuse",  // no floor-aligned pose
          "second.pcd: --fuse needs every scan's pose");
  refused("--cloud " + dir + "/first.pcd --fuse", "--fuse needs two or more scans");
  refused(dir + "/second.pcd " + dir + "/first.pcd --floor-aligned --fuse-register",
          "--fuse-register applies to --fuse");
  refused(dir + "/second.pcd " + dir + "/first.pcd --floor-aligned --fuse --fuse-planar",
          "--fuse-planar applies to --fuse-register");
}

// Issue 72: a batch killed (SIGKILL) part-way and run again with --resume
// keeps the lines it had written to <out>.partial, detects only the rest and
// writes what an uninterrupted run writes (the same inputs and detections,
// in order); the partial file is gone afterwards. Misuse is one line.
TEST_F(DetectTest, AKilledBatchResumesWithTheLinesItKept) {
  const std::string dir = testing::ScratchDir();
  const DepthFrame frame = OneChairDepth();
  std::filesystem::create_directories(dir + "/depth");
  for (int k = 0; k < 16; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "/depth/%02d.png", k);
    WriteDepthPng(frame, dir + name, 5000);
  }
  const std::string batch = std::string(FURN_WORKBENCH_BINARY) + " detect --quiet --model " +
                            *model_path_ + " '" + dir +
                            "/depth/*.png' --intrinsics 580,580,319.5,239.5 --depth-scale 5000";
  ASSERT_EQ(testing::RunCommand(batch + " --out " + dir + "/whole.jsonl").exit_code, 0);
  EXPECT_FALSE(std::filesystem::exists(dir + "/whole.jsonl.partial"));

  const std::string out = dir + "/resumed.jsonl";
  const std::string pid = testing::StartInBackground(batch + " --out " + out, "/dev/null");
  auto entries = [&] {
    const std::string text =
        std::filesystem::exists(out + ".partial") ? ReadFileBytes(out + ".partial") : std::string();
    return std::count(text.begin(), text.end(), '\n') - 1;
  };
  ASSERT_TRUE(testing::WaitUntil([&] { return entries() >= 3; }, 60));
  testing::KillHard(pid);
  ASSERT_FALSE(std::filesystem::exists(out)) << "killed after the batch finished";
  const testing::CommandResult resumed =
      testing::RunCommand(batch + " --resume --out " + out + " 2>&1");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_NE(resumed.output.find("detect: resuming: "), std::string::npos) << resumed.output;
  EXPECT_FALSE(std::filesystem::exists(out + ".partial"));
  auto lines_of = [](const std::string& path) {
    std::vector<nlohmann::json> lines;
    std::istringstream in(ReadFileBytes(path));
    for (std::string line; std::getline(in, line);) lines.push_back(nlohmann::json::parse(line));
    return lines;
  };
  const std::vector<nlohmann::json> a = lines_of(dir + "/whole.jsonl"), b = lines_of(out);
  ASSERT_EQ(a.size(), 16u);
  ASSERT_EQ(b.size(), a.size());
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(b[k]["input"], a[k]["input"]);
    EXPECT_EQ(b[k]["detections"], a[k]["detections"]);
  }
  // Another model's partial lines are not taken; misuse is one line.
  testing::WriteText(out + ".partial", "{\"furnidet_partial\":1,\"model_hash\":\"other\"}\n");
  const testing::CommandResult foreign = testing::RunCommand(batch + " --resume --out " + out);
  EXPECT_NE(foreign.exit_code, 0);
  EXPECT_NE(foreign.output.find("the lines of another run"), std::string::npos) << foreign.output;
  const testing::CommandResult no_out = testing::RunCommand(batch + " --resume");
  EXPECT_NE(no_out.output.find("--resume needs --out FILE"), std::string::npos) << no_out.output;
  const testing::CommandResult one = testing::RunCommand(
      std::string(FURN_WORKBENCH_BINARY) + " detect --model " + *model_path_ + " --depth " + dir +
      "/depth/00.png --depth-scale 5000 --resume --out " + dir + "/one.json");
  EXPECT_NE(one.output.find("--resume applies to batches"), std::string::npos) << one.output;
}

TEST_F(DetectTest, BatchOverGlobsTumListsAndBopFoldersGivesJsonLines) {
  const std::string dir = testing::ScratchDir();
  const DepthFrame frame = OneChairDepth();
  // TUM layout: depth/<timestamp>.png at 5000 units per metre, and a list.
  std::filesystem::create_directories(dir + "/tum/depth");
  WriteDepthPng(frame, dir + "/tum/depth/1.000.png", 5000);
  WriteDepthPng(frame, dir + "/tum/depth/2.000.png", 5000);
  testing::WriteText(dir + "/tum/depth.txt",
                     "# depth maps\n# file: 'x.bag'\n# timestamp filename\n1.000 "
                     "depth/1.000.png\n2.000 depth/2.000.png\n");
  // BOP layout: a scene with scene_camera.json (depth_scale: mm per unit).
  std::filesystem::create_directories(dir + "/bop/000007/depth");
  WriteDepthPng(frame, dir + "/bop/000007/depth/000003.png", 10000);
  testing::WriteText(
      dir + "/bop/000007/scene_camera.json",
      R"({"3": {"cam_K": [580, 0, 319.5, 0, 580, 239.5, 0, 0, 1], "depth_scale": 0.1}})");
  const std::string detect =
      std::string(FURN_WORKBENCH_BINARY) + " detect --quiet --model " + *model_path_;
  auto lines_of = [](const std::string& path) {
    std::vector<nlohmann::json> lines;
    std::istringstream in(ReadFileBytes(path));
    for (std::string line; std::getline(in, line);) lines.push_back(nlohmann::json::parse(line));
    return lines;
  };
  const testing::CommandResult tum = testing::RunCommand(
      detect + " " + dir + "/tum/depth.txt --intrinsics 580,580,319.5,239.5 --out " + dir +
      "/tum.jsonl");
  ASSERT_EQ(tum.exit_code, 0) << tum.output;
  const std::vector<nlohmann::json> tum_lines = lines_of(dir + "/tum.jsonl");
  ASSERT_EQ(tum_lines.size(), 2u);
  for (const nlohmann::json& line : tum_lines) {
    ASSERT_EQ(line["detections"].size(), 1u) << line.dump();
    EXPECT_EQ(line["detections"][0]["class"], "chair");
  }
  EXPECT_NE(tum_lines[1]["input"].get<std::string>().find("2.000.png"), std::string::npos);
  // Each line names the camera used, the program and the model file.
  EXPECT_EQ(tum_lines[0]["camera"]["source"], "intrinsics");
  EXPECT_EQ(tum_lines[0]["camera"]["fx"], 580);
  EXPECT_EQ(tum_lines[0]["program"].get<std::string>().rfind("furnidet ", 0), 0u);
  EXPECT_EQ(tum_lines[0]["model_file"]["path"], *model_path_);
  ContentHasher model_hash;
  const std::string model_bytes = ReadFileBytes(*model_path_);
  model_hash.Update(model_bytes.data(), model_bytes.size());
  EXPECT_EQ(tum_lines[0]["model_file"]["hash"], model_hash.HexDigest());
  // The same images by a glob and by the list, in one batch.
  const testing::CommandResult mixed = testing::RunCommand(
      detect + " '" + dir + "/tum/depth/*.png' " + dir +
      "/tum/depth.txt --intrinsics 580,580,319.5,239.5 --depth-scale 5000 --out " + dir +
      "/mixed.jsonl");
  ASSERT_EQ(mixed.exit_code, 0) << mixed.output;
  const std::vector<nlohmann::json> mixed_lines = lines_of(dir + "/mixed.jsonl");
  ASSERT_EQ(mixed_lines.size(), 4u);
  EXPECT_EQ(mixed_lines[0]["detections"], mixed_lines[2]["detections"]);
  // A BOP scene brings its own intrinsics and depth scale.
  const testing::CommandResult bop =
      testing::RunCommand(detect + " " + dir + "/bop --out " + dir + "/bop.jsonl");
  ASSERT_EQ(bop.exit_code, 0) << bop.output;
  const std::vector<nlohmann::json> bop_lines = lines_of(dir + "/bop.jsonl");
  ASSERT_EQ(bop_lines.size(), 1u);
  EXPECT_EQ(bop_lines[0]["camera"]["source"], "camera file");
  // A depth image nobody gave a camera: Kinect v1's, said on stderr.
  const testing::CommandResult assumed = testing::RunCommand(
      std::string(FURN_WORKBENCH_BINARY) + " detect --model " + *model_path_ + " --depth " + dir +
      "/tum/depth/1.000.png --depth-scale 5000 --out " + dir + "/assumed.json");
  ASSERT_EQ(assumed.exit_code, 0) << assumed.output;
  EXPECT_NE(assumed.output.find("no --intrinsics or --camera, so Kinect v1's are assumed"),
            std::string::npos)
      << assumed.output;
  EXPECT_EQ(nlohmann::json::parse(ReadFileBytes(dir + "/assumed.json"))["camera"]["source"],
            "kinect1");
  ASSERT_EQ(bop_lines[0]["detections"].size(), 1u) << bop_lines[0].dump();
  // A batch with an unreadable scan: its line says why, the others go on, exit 1.
  testing::WriteText(dir + "/tum/depth/3.000.png", "not a png");
  const testing::CommandResult partly =
      testing::RunCommand(detect + " '" + dir +
                          "/tum/depth/*.png' --intrinsics 580,580,319.5,239.5 --depth-scale 5000 "
                          "--out " +
                          dir + "/partly.jsonl");
  EXPECT_EQ(partly.exit_code, 1) << partly.output;
  EXPECT_NE(partly.output.find("1 failed"), std::string::npos) << partly.output;
  const std::vector<nlohmann::json> partly_lines = lines_of(dir + "/partly.jsonl");
  ASSERT_EQ(partly_lines.size(), 3u);
  EXPECT_TRUE(partly_lines[2].contains("error"));
  EXPECT_EQ(partly_lines[0]["detections"].size(), 1u);
  // Inputs that name nothing, and --frame without --db.
  const testing::CommandResult none = testing::RunCommand(detect + " '" + dir + "/none/*.png'");
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_NE(none.output.find("matches no file"), std::string::npos) << none.output;
  const testing::CommandResult frame_flag =
      testing::RunCommand(detect + " --depth " + dir + "/tum/depth/1.000.png --frame 5");
  EXPECT_EQ(frame_flag.exit_code, 1);
  EXPECT_NE(frame_flag.output.find("--frame 5 applies to --db only"), std::string::npos)
      << frame_flag.output;
  // --explain: every hypothesis and what became of it.
  const testing::CommandResult explain =
      testing::RunCommand(detect + " --depth " + dir +
                          "/tum/depth/1.000.png --intrinsics 580,580,319.5,239.5 "
                          "--depth-scale 5000 --explain");
  ASSERT_EQ(explain.exit_code, 0) << explain.output;
  EXPECT_NE(explain.output.find("hypotheses (Hough maxima)"), std::string::npos) << explain.output;
  EXPECT_NE(explain.output.find("-> detected"), std::string::npos) << explain.output;
}

}  // namespace
}  // namespace furn
