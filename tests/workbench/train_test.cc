// Training end to end on the procedural catalog with few views (fast).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <thread>
#include <tuple>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/detector/detector.h"
#include "core/detector/learned_source.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/parallel.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "reports/detection_debug.h"
#include "tests/test_util.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/model_info.h"
#include "workbench/pipelines/train.h"

namespace furn {
namespace {

ScanOptions FewViews() {
  ScanOptions scan;
  scan.heights_m = {1.2};
  scan.azimuths = 3;
  return scan;
}

TrainerOptions SmallVocabulary(VocabularyKind kind) {
  TrainerOptions options;
  options.vocabulary.kind = kind;
  options.vocabulary.words = 8;
  options.vocabulary.rim_lambda = 1e-5;
  return options;
}

TEST(Train, SameSeedGivesByteIdenticalModelFiles) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  const TrainSummary a =
      TrainFromCatalog(catalog, FewViews(), SmallVocabulary(VocabularyKind::kRim), dir + "/a.fcm");
  TrainFromCatalog(catalog, FewViews(), SmallVocabulary(VocabularyKind::kRim), dir + "/b.fcm");
  EXPECT_EQ(a.models, 16);
  EXPECT_EQ(a.views, 48);
  EXPECT_GT(a.segments, 100);
  EXPECT_GE(a.used_words, 2);
  EXPECT_EQ(ReadFileBytes(dir + "/a.fcm"), ReadFileBytes(dir + "/b.fcm"));
  // Load and save again: the same bytes.
  const TrainedModel model = LoadTrainedModel(dir + "/a.fcm");
  EXPECT_EQ(model.model_names.size(), 16u);
  EXPECT_EQ(model.training_segments, a.segments);
  // Each model's simplified mesh for render-and-compare.
  ASSERT_EQ(model.render_meshes.size(), 16u);
  for (const TriangleMesh& mesh : model.render_meshes) EXPECT_FALSE(mesh.Empty());
  SaveTrainedModel(model, dir + "/c.fcm");
  EXPECT_EQ(ReadFileBytes(dir + "/a.fcm"), ReadFileBytes(dir + "/c.fcm"));
  EXPECT_NE(DescribeTrainedModel(model).find("RIM (k-means init, 8 words"), std::string::npos);
  EXPECT_NE(DescribeTrainedModel(model).find("VFH size component off"), std::string::npos);
}

// The VFH size component is a trained option: stored in the model file and
// used by its part-subset library (whose descriptors then differ).
TEST(Train, VfhSizeComponentIsKeptInTheModelFile) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  TrainerOptions options = SmallVocabulary(VocabularyKind::kKMeans);
  TrainFromCatalog(catalog, FewViews(), options, dir + "/plain.fcm");
  options.part_subsets.vfh_size_component = true;
  TrainFromCatalog(catalog, FewViews(), options, dir + "/sized.fcm");
  const TrainedModel plain = LoadTrainedModel(dir + "/plain.fcm");
  const TrainedModel sized = LoadTrainedModel(dir + "/sized.fcm");
  EXPECT_FALSE(plain.options.part_subsets.vfh_size_component);
  EXPECT_TRUE(sized.options.part_subsets.vfh_size_component);
  EXPECT_NE(DescribeTrainedModel(sized).find("VFH size component on"), std::string::npos);
  EXPECT_EQ(plain.part_models, sized.part_models);  // the same subsets,
  EXPECT_FALSE(plain.part_index.projected.isApprox(sized.part_index.projected));  // other VFHs
  SaveTrainedModel(sized, dir + "/again.fcm");
  EXPECT_EQ(ReadFileBytes(dir + "/sized.fcm"), ReadFileBytes(dir + "/again.fcm"));
}

TEST(Train, ScaleVariantsAddAugmentedViewsButKeepTheTrueShapes) {
  Progress::SetQuiet(true);
  const Catalog catalog = OpenCatalog("procedural:2");
  const CatalogEntry* entry = catalog.Classified().front();
  const LoadedModels loaded = catalog.LoadModels({entry->id});
  ScanOptions scan = FewViews();
  const std::vector<TrainingView> plain =
      ScanModel(loaded.models[0], 0, *entry->furniture_class, scan);
  scan.scale_variants = 2;
  scan.scale_jitter = 0.2;
  const std::vector<TrainingView> augmented =
      ScanModel(loaded.models[0], 0, *entry->furniture_class, scan);
  ASSERT_EQ(augmented.size(), 3 * plain.size());
  for (size_t v = 0; v < plain.size(); ++v) {  // the true-size views are unchanged
    EXPECT_FALSE(augmented[v].augmented);
    EXPECT_EQ(augmented[v].points, plain[v].points);
  }
  // The variants are other sizes, within the jitter, and differ from each other.
  auto extent = [](const std::vector<TrainingView>& views, size_t first, size_t count) {
    Eigen::AlignedBox3f box;
    for (size_t v = first; v < first + count; ++v) {
      for (const Eigen::Vector3f& p : views[v].points) box.extend(p);
    }
    return Eigen::Vector3f(box.sizes());
  };
  const Eigen::Vector3f size = extent(plain, 0, plain.size());
  const Eigen::Vector3f first = extent(augmented, plain.size(), plain.size());
  const Eigen::Vector3f second = extent(augmented, 2 * plain.size(), plain.size());
  EXPECT_TRUE(augmented[plain.size()].augmented);
  EXPECT_GT((first - size).norm(), 0.01f);
  EXPECT_GT((first - second).norm(), 0.01f);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_GT(first[axis], 0.75f * size[axis]);
    EXPECT_LT(first[axis], 1.25f * size[axis]);
  }
  // Fitting and verification use the true shape only.
  const TrainerOptions trainer = SmallVocabulary(VocabularyKind::kKMeans);
  const TrainedModel a = TrainModel(plain, {entry->id}, {*entry->furniture_class}, trainer);
  const TrainedModel b = TrainModel(augmented, {entry->id}, {*entry->furniture_class}, trainer);
  EXPECT_EQ(a.model_shapes[0].points, b.model_shapes[0].points);
  EXPECT_GT(b.training_segments, 2 * a.training_segments);
  EXPECT_GT(b.part_models.size(), a.part_models.size());
  scan.scale_variants = 11;
  EXPECT_NE(testing::ErrorOf([&] { scan.Check(); }).find("scale variants 11 must be in 0..10"),
            std::string::npos);
}

TEST(Train, KMeansVocabularyAndOtherSeedDiffer) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  TrainerOptions options = SmallVocabulary(VocabularyKind::kKMeans);
  TrainFromCatalog(catalog, FewViews(), options, dir + "/a.fcm");
  options.vocabulary.seed = 2;
  TrainFromCatalog(catalog, FewViews(), options, dir + "/b.fcm");
  EXPECT_NE(ReadFileBytes(dir + "/a.fcm"), ReadFileBytes(dir + "/b.fcm"));
  EXPECT_EQ(LoadTrainedModel(dir + "/a.fcm").vocabulary.NumWords(), 8);
}

TEST(Train, BadModelFilesAreRejected) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/foreign.fcm", "this is not a model file at all");
  EXPECT_NE(testing::ErrorOf([&] {
              LoadTrainedModel(dir + "/foreign.fcm");
            }).find("not a furnidet model file"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] { LoadTrainedModel(dir + "/missing.fcm"); }).find("cannot read"),
            std::string::npos);
  Progress::SetQuiet(true);
  TrainFromCatalog(OpenCatalog("procedural:2"),
                   FewViews(),
                   SmallVocabulary(VocabularyKind::kKMeans),
                   dir + "/good.fcm");
  const std::string bytes = ReadFileBytes(dir + "/good.fcm");
  testing::WriteText(dir + "/truncated.fcm", bytes.substr(0, bytes.size() / 2));
  EXPECT_NE(testing::ErrorOf([&] { LoadTrainedModel(dir + "/truncated.fcm"); }).find("truncated"),
            std::string::npos);
  // Any damaged byte of the payload: the checksum says so, one line, nothing
  // parsed (200 single-byte flips over the file, and the render meshes' last one).
  for (size_t k = 0; k <= 200; ++k) {
    std::string damaged = bytes;
    const size_t at = k < 200 ? 12 + (k * 7919u) % (bytes.size() - 12) : bytes.size() - 10;
    damaged[at] = static_cast<char>(damaged[at] ^ (1 << (k % 8)));
    testing::WriteText(dir + "/damaged.fcm", damaged);
    EXPECT_NE(testing::ErrorOf([&] {
                LoadTrainedModel(dir + "/damaged.fcm");
              }).find("damaged (checksum mismatch)"),
              std::string::npos)
        << "byte " << at;
  }
  std::string newer = bytes;
  newer[8] = 11;  // format version
  testing::WriteText(dir + "/newer.fcm", newer);
  EXPECT_NE(
      testing::ErrorOf([&] { LoadTrainedModel(dir + "/newer.fcm"); }).find("format version 11"),
      std::string::npos);
}

// The vote network (issue 30): trained from rooms without the held-out
// models, stored in the model file and read back byte for byte; a garbled
// network block (under a valid checksum) is one line naming it; detection
// votes with it by default and with the codebook when asked.
TEST(Train, VoteNetIsStoredUsedAndItsRoomsHoldNoHeldOutModel) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  const std::string held_out = catalog.Classified().front()->id;
  VoteNetTrainingOptions vote;
  vote.rooms = 4;
  vote.frames_per_room = 2;
  vote.epochs = 1;
  vote.net.width = 4;
  vote.keep_rooms = true;
  vote.quiet = true;
  const TrainSummary summary = TrainFromCatalog(catalog,
                                                FewViews(),
                                                SmallVocabulary(VocabularyKind::kKMeans),
                                                dir + "/net.fcm",
                                                {held_out},
                                                "",
                                                &vote);
  ASSERT_TRUE(summary.vote_net);
  EXPECT_EQ(summary.vote_net_training.epochs.size(), 1u);
  {
    DatasetDb rooms(dir + "/net.fcm.rooms.db", DatasetDb::Mode::kReadOnly);
    int objects = 0;
    for (int64_t id : rooms.RoomIds()) {
      for (const ObjectRecord& object : rooms.ReadRoom(id, false).objects) {
        EXPECT_NE(object.model_id, held_out);
        objects += object.furniture_class.has_value();
      }
    }
    EXPECT_GT(objects, 4);
  }
  TrainedModel model = LoadTrainedModel(dir + "/net.fcm");
  ASSERT_FALSE(model.vote_net.empty());
  EXPECT_EQ(VoteNet::Deserialize(model.vote_net, "net").Serialize(), model.vote_net);
  EXPECT_NE(DescribeTrainedModel(model).find("vote net:    U-Net"), std::string::npos);
  DetectorOptions network_only;
  network_only.learned_fit = false;
  const Detector learned_detector(model, network_only);
  EXPECT_TRUE(learned_detector.learned());
  EXPECT_TRUE(Detector(model, DetectorOptions{}).learned());
  {  // The learned path on a frame of its own rooms: floor, bev, network, maxima.
    DatasetDb rooms(dir + "/net.fcm.rooms.db", DatasetDb::Mode::kReadOnly);
    const RoomRecord room = rooms.ReadRoom(rooms.RoomIds().front(), true);
    const DetectionResult result =
        learned_detector.Detect(DetectionInputOf(room.frames.front(), "frame"), true);
    std::vector<DetectionStage> stages;
    for (const StageTime& t : result.timings_ms.stages) stages.push_back(t.stage);
    EXPECT_EQ(stages,
              (std::vector<DetectionStage>{DetectionStage::kFloor,
                                           DetectionStage::kBev,
                                           DetectionStage::kNetwork,
                                           DetectionStage::kMaxima,
                                           DetectionStage::kTotal}));
    EXPECT_EQ(result.debug.grids.size(), kAllClasses.size());
    // Detection rasterises the range its network was trained on (stored with
    // the weights), whatever the detector's --max-range: a network of 1 m
    // sees no point beyond it.
    TrainedModel near = model;
    const double one_metre = 1.0;
    std::memcpy(&near.vote_net[68], &one_metre, sizeof(one_metre));  // the range field
    DetectorOptions far = network_only;
    far.max_range_m = 4;
    const DetectionResult cut =
        Detector(near, far).Detect(DetectionInputOf(room.frames.front(), "frame"), true);
    const Eigen::Vector3f sensor =
        room.frames.front().world_from_camera.translation().cast<float>();
    float farthest = 0;
    for (const Eigen::Vector3f& p : cut.debug.points)
      farthest = std::max(farthest, (p - sensor).norm());
    EXPECT_LE(farthest, 1.0f + 1e-4f);
    EXPECT_LT(cut.debug.points.size(), result.debug.points.size());
    // Its maxima farther across the floor than the detector's range are not
    // reported (the network sees its own range for context).
    auto farthest_maximum = [&](const DetectionResult& r) {
      double metres = 0;
      for (const DetectionDebug::Hypothesis& h : r.debug.hypotheses)
        metres = std::max(metres, std::hypot(h.x - sensor.x(), h.y - sensor.y()));
      return metres;
    };
    DetectorOptions every_maximum = network_only;
    every_maximum.learned_decode.min_heat = 0;  // up to 16 per class, anywhere
    const DetectionResult all =
        Detector(model, every_maximum).Detect(DetectionInputOf(room.frames.front(), "frame"), true);
    every_maximum.max_range_m = 1.5;
    const DetectionResult near_only =
        Detector(model, every_maximum).Detect(DetectionInputOf(room.frames.front(), "frame"), true);
    EXPECT_GT(farthest_maximum(all), 1.5);
    EXPECT_LE(farthest_maximum(near_only), 1.5);
    for (const DetectionDebug::Hypothesis& h : result.debug.hypotheses)
      EXPECT_TRUE(h.learned.has_value());
    for (const Detection& d : result.detections) {
      EXPECT_EQ(d.model_index, -1);
      EXPECT_GT(d.width, 0);
    }
    // With the paper's stages after the vote: a fit that agrees names its
    // CAD model and gives the yaw (here every fit agrees: 2 m).
    DetectorOptions fitting;
    fitting.learned_fit = true;
    fitting.learned_fit_agree_m = 2.0;
    fitting.learned_decode.min_heat = 0.0;
    const DetectionResult fitted =
        Detector(model, fitting).Detect(DetectionInputOf(room.frames.front(), "frame"), true);
    stages.clear();
    for (const StageTime& t : fitted.timings_ms.stages) stages.push_back(t.stage);
    EXPECT_NE(std::find(stages.begin(), stages.end(), DetectionStage::kFitAndVerify), stages.end());
    // Issue 70: the segmentation runs beside the network and computes no
    // SGFs (no codebook words on this path); the same detections whichever
    // thread gets the pool, e.g. while another loop holds it.
    EXPECT_NE(std::find(stages.begin(), stages.end(), DetectionStage::kSegment), stages.end());
    EXPECT_EQ(std::find(stages.begin(), stages.end(), DetectionStage::kFeatures), stages.end());
    const Detector fitting_detector(model, fitting);
    DetectionResult contended;
    RunBeside(
        [&] {
          ParallelFor(
              0, 64, [](int) { std::this_thread::sleep_for(std::chrono::milliseconds(2)); });
        },
        [&] {
          contended = fitting_detector.Detect(DetectionInputOf(room.frames.front(), "frame"), true);
        });
    ASSERT_EQ(contended.detections.size(), fitted.detections.size());
    for (size_t i = 0; i < fitted.detections.size(); ++i) {
      const Detection &a = fitted.detections[i], &b = contended.detections[i];
      EXPECT_EQ(std::tie(a.x, a.y, a.yaw, a.score, a.model_index, a.width, a.depth),
                std::tie(b.x, b.y, b.yaw, b.score, b.model_index, b.width, b.depth));
    }
    EXPECT_EQ(contended.segments, fitted.segments);
    int refined = 0, k = 0;
    for (const DetectionDebug::Hypothesis& h : fitted.debug.hypotheses) {
      if (h.outcome != HypothesisOutcome::kDetected) continue;
      const Detection& d = fitted.detections.at(k++);
      if (!h.learned->refined) {
        EXPECT_EQ(d.model_index, -1);
        continue;
      }
      ++refined;
      ASSERT_GE(d.model_index, 0);
      EXPECT_EQ(model.model_classes[d.model_index], h.furniture_class);
      EXPECT_EQ(d.model_name, model.model_names[d.model_index]);
      EXPECT_EQ(d.x, h.x);  // the network's position, the fit's yaw
      EXPECT_EQ(d.y, h.y);
      const auto best =
          std::max_element(h.fits.begin(), h.fits.end(), [](const auto& a, const auto& b) {
            return a.score < b.score;
          });
      ASSERT_NE(best, h.fits.end());
      EXPECT_EQ(d.yaw, best->yaw);
      EXPECT_EQ(d.model_index, best->model_index);
      EXPECT_FALSE(h.segments.empty());
    }
    EXPECT_EQ(k, static_cast<int>(fitted.detections.size()));
    EXPECT_GT(refined, 0) << "no hypothesis was fitted";
    {  // Issue 71: the learned source's stages called alone give Detect's detections.
      const DetectionInput input = DetectionInputOf(room.frames.front(), "frame");
      const LearnedSource source(fitting_detector);
      PreparedScan scan = fitting_detector.Prepare(input);
      SetTorchThreads(fitting.torch_threads);  // as Detect's network thread
      const BevImage image = source.Rasterise(scan);
      const BevOutput output = source.RunNetwork(image);
      Proposals proposals = source.Decode(image, output);
      proposals.image = image;  // what the extent fit reads
      EXPECT_EQ(proposals.hypotheses.size(), fitted.debug.hypotheses.size());
      KeepAtOperatingPoint(fitting_detector.operating_point(), &proposals);
      source.FitCandidates(scan, &proposals);
      source.FitExtents(scan, &proposals);
      ASSERT_EQ(proposals.candidates.size(), fitted.detections.size());
      for (size_t i = 0; i < fitted.detections.size(); ++i) {
        const Detection &a = fitted.detections[i], &b = proposals.candidates[i].detection;
        EXPECT_EQ(std::tie(a.x, a.y, a.yaw, a.score, a.model_index, a.width, a.depth),
                  std::tie(b.x, b.y, b.yaw, b.score, b.model_index, b.width, b.depth));
      }
      // Without a vote network there is no learned source.
      EXPECT_NE(testing::ErrorOf([&] {
                  DetectorOptions codebook;
                  codebook.voting = VotingMode::kCodebook;
                  const Detector plain(model, codebook);
                  LearnedSource{plain};
                }).find("does not vote with a network"),
                std::string::npos);
    }
    // Its debug figures show what it did: heat under the points and boxes in
    // class colours, not grey points; no segments figure on this path.
    std::filesystem::create_directories(dir + "/debug");
    testing::WriteText(dir + "/debug/segments.png", "a codebook run's figure");
    WriteDetectionDebug(fitted, model, CameraIntrinsics::KinectV1(), {}, dir + "/debug");
    EXPECT_FALSE(std::filesystem::exists(dir + "/debug/segments.png"));
    for (const char* png : {"heat.png", "fitted.png"}) {
      const cv::Mat image = cv::imread(dir + "/debug/" + png);
      ASSERT_FALSE(image.empty()) << png;
      int coloured = 0;
      for (auto it = image.begin<cv::Vec3b>(); it != image.end<cv::Vec3b>(); ++it) {
        const cv::Vec3b c = *it;
        coloured += std::max({c[0], c[1], c[2]}) - std::min({c[0], c[1], c[2]}) > 60;
      }
      EXPECT_GT(coloured, 200) << png << " is grey";
    }
    // Its 3-D page has the heat on the floor, and hiding it changes the picture.
    std::string output;
    const std::string text = testing::SceneSelfTest(dir + "/debug/scene.html", &output);
    ASSERT_FALSE(text.empty()) << output;
    const nlohmann::json check = nlohmann::json::parse(text);
    EXPECT_EQ(check["errors"].size(), 0u) << text;
    EXPECT_EQ(check["objects"]["heat"], 1) << text;
    EXPECT_EQ(check["objects"]["detections"].get<size_t>(), fitted.detections.size());
    EXPECT_TRUE(check["toggles"]["heat"].get<bool>());
    EXPECT_LT(check["drawn"]["without_heat"], check["drawn"]["all"]) << text;
    EXPECT_TRUE(std::filesystem::exists(dir + "/debug/three/VERSION"));
  }
  {  // The operating point: a candidate below its class's threshold is no
     // detection; it is stored in the model file; all_candidates and a
     // per-class override bring the candidates back.
    DatasetDb rooms(dir + "/net.fcm.rooms.db", DatasetDb::Mode::kReadOnly);
    const RoomRecord room = rooms.ReadRoom(rooms.RoomIds().front(), true);
    const DetectionInput input = DetectionInputOf(room.frames.front(), "frame");
    DetectorOptions options = network_only;
    options.learned_decode.min_heat = 0.0;
    const DetectionResult every = Detector(model, options).Detect(input, false);
    ASSERT_GE(every.detections.size(), 2u);
    std::vector<double> scores;
    for (const Detection& d : every.detections) scores.push_back(d.score);
    std::sort(scores.begin(), scores.end());
    const double cut = scores[scores.size() / 2];
    const size_t above = scores.end() - std::lower_bound(scores.begin(), scores.end(), cut);
    TrainedModel with_point = model;
    for (ClassOperatingPoint& c : with_point.operating_point.classes) c.min_score = cut;
    with_point.operating_point.chosen_on = "a test";
    SaveTrainedModel(with_point, dir + "/point.fcm");
    const TrainedModel loaded = LoadTrainedModel(dir + "/point.fcm");
    EXPECT_EQ(loaded.operating_point.MinScore(FurnitureClass::kTable), cut);
    EXPECT_EQ(loaded.operating_point.chosen_on, "a test");
    EXPECT_NE(DescribeTrainedModel(loaded).find("operating point: least score per class"),
              std::string::npos);
    const DetectionResult kept = Detector(loaded, options).Detect(input, true);
    EXPECT_EQ(kept.detections.size(), above);
    for (const Detection& d : kept.detections) EXPECT_GE(d.score, cut);
    int below = 0;
    for (const DetectionDebug::Hypothesis& h : kept.debug.hypotheses) {
      if (h.outcome != HypothesisOutcome::kBelowOperatingPoint) continue;
      ++below;
      EXPECT_LT(h.outcome_values[0], cut);
      EXPECT_NE(DetectionDebug::Describe(h).find("below the operating point"), std::string::npos);
    }
    EXPECT_EQ(below, static_cast<int>(every.detections.size() - above));
    options.all_candidates = true;
    EXPECT_EQ(Detector(loaded, options).Detect(input, false).detections.size(),
              every.detections.size());
    options.all_candidates = false;
    options.class_min_score.fill(0.0);
    EXPECT_EQ(Detector(loaded, options).Detect(input, false).detections.size(),
              every.detections.size());
    options.class_min_score[0] = 1.5;
    EXPECT_NE(testing::ErrorOf([&] { options.Check(); }).find("operating point of chair"),
              std::string::npos);
  }
  {  // What the network was trained on: recorded, read back, described, and
     // a note when detection gives it the other kind of input.
    EXPECT_TRUE(model.vote_net_input.SingleFrames());
    EXPECT_NE(DescribeTrainedModel(model).find("vote net input: single frames"), std::string::npos);
    EXPECT_NE(VoteNetInputNote(model, "m.fcm", true)
                  .find("m.fcm: its vote network was trained "
                        "on single frames"),
              std::string::npos);
    EXPECT_EQ(VoteNetInputNote(model, "m.fcm", false), "");
    TrainedModel fused = model;
    fused.vote_net_input.fused_share = 0.5;
    fused.vote_net_input.pose_noise_m = 0.02;
    fused.vote_net_input.pose_noise_deg = 1;
    SaveTrainedModel(fused, dir + "/fused.fcm");
    const TrainedModel loaded = LoadTrainedModel(dir + "/fused.fcm");
    EXPECT_TRUE(loaded.vote_net_input.Fused());
    EXPECT_EQ(loaded.vote_net_input.pose_noise_m, 0.02);
    EXPECT_NE(DescribeTrainedModel(loaded).find(
                  "vote net input: fused frames in 50 % of its training, their room-mates off by "
                  "2 cm / 1 deg"),
              std::string::npos);
    EXPECT_NE(VoteNetInputNote(loaded, "f.fcm", false).find("trained for fused scans"),
              std::string::npos);
    EXPECT_EQ(VoteNetInputNote(loaded, "f.fcm", true), "");
    // An older file upgraded (format 9 and before recorded nothing) stays unknown.
    TrainedModel unknown = model;
    unknown.vote_net_input = VoteNetInput{};
    SaveTrainedModel(unknown, dir + "/unknown.fcm");
    const TrainedModel reread = LoadTrainedModel(dir + "/unknown.fcm");
    EXPECT_FALSE(reread.vote_net_input.recorded);
    EXPECT_NE(DescribeTrainedModel(reread).find("vote net input: not recorded"), std::string::npos);
    EXPECT_EQ(VoteNetInputNote(reread, "u.fcm", true), "");
    TrainedModel codebook_only = loaded;
    codebook_only.vote_net.clear();
    EXPECT_EQ(VoteNetInputNote(codebook_only, "c.fcm", false), "");
    // Out of range under a valid checksum: one line naming the file and field.
    fused.vote_net_input.fused_share = 2;
    SaveTrainedModel(fused, dir + "/share.fcm");
    EXPECT_NE(testing::ErrorOf([&] { LoadTrainedModel(dir + "/share.fcm"); })
                  .find("share.fcm: model file is corrupt (the vote network's training input "
                        "fused share 2.000000 must be in 0..1)"),
              std::string::npos);
    fused.vote_net_input.fused_share = 0.5;
    fused.vote_net_input.pose_noise_deg = std::nan("");
    SaveTrainedModel(fused, dir + "/noise.fcm");
    EXPECT_NE(testing::ErrorOf([&] {
                LoadTrainedModel(dir + "/noise.fcm");
              }).find("fused pose error nan degrees must be in 0..45 degrees)"),
              std::string::npos);
  }
  DetectorOptions codebook;
  codebook.voting = VotingMode::kCodebook;
  EXPECT_FALSE(Detector(model, codebook).learned());

  // Without keep_rooms the rooms' database goes, with SQLite's files beside it.
  vote.keep_rooms = false;
  TrainFromCatalog(catalog,
                   FewViews(),
                   SmallVocabulary(VocabularyKind::kKMeans),
                   dir + "/gone.fcm",
                   {},
                   "",
                   &vote);
  for (const char* suffix : {"", "-wal", "-shm"})
    EXPECT_FALSE(std::filesystem::exists(dir + "/gone.fcm.rooms.db" + suffix)) << suffix;

  model.vote_net = "FURNVNET" + std::string(200, 'q');
  SaveTrainedModel(model, dir + "/garbled.fcm");
  const std::string garbled =
      testing::ErrorOf([&] { Detector(LoadTrainedModel(dir + "/garbled.fcm"), {}); });
  EXPECT_NE(garbled.find("vote network"), std::string::npos) << garbled;
  EXPECT_EQ(garbled.find('\n'), std::string::npos) << garbled;

  TrainFromCatalog(
      catalog, FewViews(), SmallVocabulary(VocabularyKind::kKMeans), dir + "/plain.fcm");
  DetectorOptions learned;
  learned.voting = VotingMode::kLearned;
  const std::string none =
      testing::ErrorOf([&] { Detector(LoadTrainedModel(dir + "/plain.fcm"), learned); });
  EXPECT_NE(none.find("holds no vote network"), std::string::npos) << none;
  EXPECT_FALSE(Detector(LoadTrainedModel(dir + "/plain.fcm"), {}).learned());
}

TEST(Train, TooFewSegmentsForTheVocabularyIsRejected) {
  Progress::SetQuiet(true);
  TrainerOptions options = SmallVocabulary(VocabularyKind::kKMeans);
  options.vocabulary.words = 1000;
  const std::string message = testing::ErrorOf([&] {
    TrainFromCatalog(
        OpenCatalog("procedural:2"), FewViews(), options, testing::ScratchDir() + "/x.fcm");
  });
  EXPECT_NE(message.find("fewer than the 1000 words"), std::string::npos) << message;
  EXPECT_THROW(TrainModel({}, {}, {}, TrainerOptions{}), InputError);
}

}  // namespace
}  // namespace furn

#include <filesystem>

#include "workbench/pipelines/eval_parts.h"

namespace furn {
namespace {

TEST(EvalParts, ClassifiesPartSubsetsBetterThanChanceAndReproducibly) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  TrainFromCatalog(catalog, FewViews(), SmallVocabulary(VocabularyKind::kKMeans), dir + "/m.fcm");
  const TrainedModel model = LoadTrainedModel(dir + "/m.fcm");
  PartEvaluationOptions options;
  options.scan = FewViews();
  options.scan.azimuths = 6;
  options.repetitions = 3;
  const PartEvaluation a = EvaluatePartSubsets(catalog, model, options);
  options.neighbours = 3;  // a k-NN vote, and the same result twice
  const PartEvaluation b = EvaluatePartSubsets(catalog, model, options);
  EXPECT_EQ(b.model_accuracy, EvaluatePartSubsets(catalog, model, options).model_accuracy);
  EXPECT_GT(b.category_mean, 0.5);
  options.neighbours = 1;
  EXPECT_EQ(a.views, 96);
  EXPECT_GT(a.subsets, 500);
  EXPECT_GT(a.category_mean, 0.5);    // chance is 0.25 with four classes
  EXPECT_GT(a.model_mean, 1.0 / 16);  // chance over sixteen models
  ASSERT_EQ(a.classes.size(), 4u);
  int64_t total = 0;
  for (const auto& row : a.confusion)
    for (int64_t c : row) total += c;
  EXPECT_GT(total, 0);
  WritePartEvaluation(a, dir + "/out");
  EXPECT_TRUE(std::filesystem::exists(dir + "/out/parts.json"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/out/confusion.png"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/out/confusion_models.png"));
  ASSERT_EQ(a.model_confusion.size(), 16u);
  int64_t model_total = 0;
  for (size_t m = 0; m < a.model_confusion.size(); ++m)
    for (int64_t c : a.model_confusion[m]) model_total += c;
  EXPECT_EQ(model_total, total);

  // Split by subset, as the paper did: a fifth of the subsets is tested in
  // each repetition, and the parts they share with library subsets of the
  // same view make it easier than held-out views.
  options.split = PartSplit::kBySubset;
  const PartEvaluation by_subset = EvaluatePartSubsets(catalog, model, options);
  EXPECT_NEAR(static_cast<double>(model_total) / (options.repetitions * a.subsets), 0.2, 0.08);
  int64_t subset_total = 0;
  for (const auto& row : by_subset.confusion)
    for (int64_t c : row) subset_total += c;
  EXPECT_NEAR(
      static_cast<double>(subset_total) / (options.repetitions * by_subset.subsets), 0.2, 0.03);
  EXPECT_GT(by_subset.model_mean, a.model_mean);
  EXPECT_EQ(ParsePartSplit("subset"), PartSplit::kBySubset);
  EXPECT_THROW(ParsePartSplit("views"), InputError);
  options.split = PartSplit::kByView;
  options.index_dimensions = 309;
  EXPECT_THROW(EvaluatePartSubsets(catalog, model, options), InputError);
  options.index_dimensions = 308;  // plain L2
  EXPECT_GT(EvaluatePartSubsets(catalog, model, options).category_mean, 0.5);

  options.neighbours = 0;
  EXPECT_THROW(EvaluatePartSubsets(catalog, model, options), InputError);
  options.neighbours = 1;
  options.repetitions = 0;
  EXPECT_THROW(EvaluatePartSubsets(catalog, model, options), InputError);
}

}  // namespace
}  // namespace furn
