// Issue 73: scoring detections another program wrote (evaluate
// --detections), the format's reader and writer, and the png and pcd
// exports read back by readers that are not the writer's (PCL, NumPy).
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "tests/test_util.h"
#include "tests/workbench/workbench_commands.h"
#include "workbench/formats/external_detections.h"

namespace furn {
namespace {

testing::CommandResult Workbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
}

ScoredDetection Chair() {
  OrientedBox box;
  box.centre = Eigen::Vector3d(1.25, -0.5, 0.45);
  box.size = Eigen::Vector3d(0.5, 0.45, 0.9);
  box.yaw = 0.3;
  ScoredDetection d = ScoredDetectionOfBox(FurnitureClass::kChair, 0.875, box);
  d.x = 1.2;  // a floor point apart from the box's centre
  d.model_id = "Scopia/chair3";
  return d;
}

TEST(ExternalDetections, ALineWrittenReadsBackToTheSameDetection) {
  const std::string dir = testing::ScratchDir();
  const ScoredDetection chair = Chair();
  testing::WriteText(dir + "/d.jsonl",
                     ExternalDetectionsLine(7, {chair}, "test", 12.5) +
                         ExternalDetectionsLine(9, {}, "test", std::nullopt));
  const ExternalDetections read = ReadExternalDetections(dir + "/d.jsonl");
  ASSERT_EQ(read.frames.size(), 2u);
  EXPECT_EQ(read.detector, "test");
  EXPECT_EQ(read.frames.at(7).time_ms, 12.5);
  EXPECT_FALSE(read.frames.at(9).time_ms.has_value());
  EXPECT_TRUE(read.frames.at(9).detections.empty());
  ASSERT_EQ(read.frames.at(7).detections.size(), 1u);
  const ScoredDetection& d = read.frames.at(7).detections[0];
  EXPECT_EQ(d.furniture_class, FurnitureClass::kChair);
  EXPECT_EQ(d.score, chair.score);
  EXPECT_EQ(d.x, 1.2);
  EXPECT_EQ(d.y, chair.y);
  EXPECT_EQ(d.model_id, "Scopia/chair3");
  EXPECT_EQ(d.symmetry, 1);
  EXPECT_EQ(d.width, 0.45);  // a network's footprint: across the front
  EXPECT_EQ(d.depth, 0.5);
  EXPECT_EQ(d.box3d.centre, chair.box3d.centre);
  EXPECT_EQ(d.box3d.size, chair.box3d.size);
  EXPECT_NEAR(d.box3d.yaw, 0.3, 1e-15);
  // The REP 103 yaw's front is x; the CAD yaw's is -y: a quarter turn apart.
  EXPECT_NEAR(d.yaw, 0.3 + M_PI / 2, 1e-12);
}

TEST(ExternalDetections, DetectOutputOfADatasetFrameIsReadWithItsPose) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/detect.json", R"({
  "format": 2,
  "input": "synth.db frame 12",
  "dataset_frame": 12,
  "floor_estimated": true,
  "world_from_camera": [[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 1.2], [0, 0, 0, 1]],
  "program": "furnidet 0.1.0",
  "detections": [{"class": "table", "score": 0.5, "centre": [1, 2, 0.37], "size": [0.8, 1.4, 0.74],
                  "yaw": 0.1, "floor_point": [1, 2], "model": null, "size_source": "model"}]
})");
  const ExternalDetections read = ReadExternalDetections(dir);
  ASSERT_EQ(read.frames.count(12), 1u);
  const ExternalFrame& frame = read.frames.at(12);
  ASSERT_TRUE(frame.detector_world_from_camera.has_value());
  EXPECT_EQ(frame.detector_world_from_camera->translation(), Eigen::Vector3d(0.5, 0, 1.2));
  ASSERT_EQ(frame.detections.size(), 1u);
  EXPECT_EQ(frame.detections[0].width, 0);     // a model's size is no footprint estimate
  EXPECT_EQ(frame.detections[0].symmetry, 2);  // a table's
  EXPECT_EQ(read.detector, "furnidet 0.1.0");
}

// Every malformed file: one line naming the file, the line and the field.
TEST(ExternalDetections, MalformedFilesGetOneLineNamingFileLineAndField) {
  const std::string dir = testing::ScratchDir();
  const std::string good =
      R"({"format": "furnidet-detections", "version": 1, "frame": 1, "detections": []})";
  const std::string box = R"("centre": [1, 2, 0.4], "size": [0.5, 0.5, 0.9], "yaw": 0)";
  const std::map<std::string, std::string> cases = {
      {"{\"format\": \"furnidet-detections\", \"version\": 1,", "d.jsonl:2: not JSON"},
      {R"({"format": "kitti", "version": 1, "frame": 2, "detections": []})",
       "d.jsonl:2: \"format\" must be \"furnidet-detections\""},
      {R"({"format": "furnidet-detections", "version": 2, "frame": 2, "detections": []})",
       "d.jsonl:2: \"version\" is 2: written for a newer workbench"},
      {R"({"format": "furnidet-detections", "version": 1, "frame": -3, "detections": []})",
       "d.jsonl:2: \"frame\" must be a dataset frame id"},
      {R"({"format": "furnidet-detections", "version": 1, "frame": 1, "detections": []})",
       "d.jsonl:2: \"frame\" 1 comes twice (first at "},
      {R"({"format": "furnidet-detections", "version": 1, "frame": 2})",
       "d.jsonl:2: \"detections\" is missing"},
      {R"({"format": "furnidet-detections", "version": 1, "frame": 2, "detections": [{"class": "bed", "score": 1, )" +
           box + "}]}",
       "d.jsonl:2: \"detections[0].class\" is \"bed\", not one of chair, armchair, table"},
      {R"({"format": "furnidet-detections", "version": 1, "frame": 2, "detections": [{"class": "chair", "score": "high", )" +
           box + "}]}",
       "d.jsonl:2: \"detections[0].score\" must be a number"},
      {R"({"format": "furnidet-detections", "version": 1, "frame": 2, "detections": [{"class": "chair", "score": 1, "centre": [1, 2], "size": [1, 1, 1], "yaw": 0}]})",
       "d.jsonl:2: \"detections[0].centre\" must be an array of 3 numbers"},
      {R"({"format": "furnidet-detections", "version": 1, "frame": 2, "detections": [{"class": "chair", "score": 1, "centre": [1, 2, 0], "size": [1, -1, 1], "yaw": 0}]})",
       "d.jsonl:2: \"detections[0].size\" must not be negative"},
      {R"({"format": "furnidet-detections", "version": 1, "frame": 2, "detections": [{"class": "chair", "score": 1e999, )" +
           box + "}]}",
       "d.jsonl:2: not JSON"},  // 1e999 overflows: nlohmann refuses it
      {R"({"format": "furnidet-detections", "version": 1, "frame": 2, "detections": [{"class": "chair", "score": 1, "symmetry": 3, )" +
           box + "}]}",
       "d.jsonl:2: \"detections[0].symmetry\" must be 1, 2 or 4"},
      {R"({"format": 2, "input": "scan.pcd", "detections": []})",
       "d.jsonl:2: \"dataset_frame\" is missing: only detect's output for a dataset frame"},
      {std::string(100, '[') + std::string(100, ']'), "d.jsonl:2: JSON nested deeper than 64"},
  };
  for (const auto& [second_line, expected] : cases) {
    testing::WriteText(dir + "/d.jsonl", good + "\n" + second_line + "\n");
    const std::string error = testing::ErrorOf([&] { ReadExternalDetections(dir + "/d.jsonl"); });
    EXPECT_NE(error.find(expected), std::string::npos) << error << "\n  expected: " << expected;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
  testing::WriteText(dir + "/empty.jsonl", "\n\n");
  EXPECT_NE(testing::ErrorOf([&] {
              ReadExternalDetections(dir + "/empty.jsonl");
            }).find("empty.jsonl: is empty"),
            std::string::npos);
  std::filesystem::create_directories(dir + "/none");
  EXPECT_NE(testing::ErrorOf([&] {
              ReadExternalDetections(dir + "/none");
            }).find("has no .jsonl or .json file"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] {
              ReadExternalDetections(dir + "/missing.jsonl");
            }).find("missing.jsonl: no such detections file"),
            std::string::npos);
}

// A small dataset and codebook model shared by the scoring tests.
class ExternalScoring : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = testing::ScratchDir();
    db_ = dir_ + "/d.db";
    model_ = dir_ + "/m.fcm";
    ASSERT_EQ(Workbench("generate --catalog procedural:4 --rooms 4 --frames 2 --seed 5 --quiet "
                        "--out " +
                        db_)
                  .exit_code,
              0);
    ASSERT_EQ(Workbench(std::string(testing::kTrainSmallCodebook) + model_).exit_code, 0);
  }

  // The latest run's metrics.
  static std::map<std::string, double> LatestMetrics(const std::string& db) {
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    return dataset.RunMetrics(dataset.Runs().back().id);
  }

  static std::string dir_, db_, model_;
};
std::string ExternalScoring::dir_, ExternalScoring::db_, ExternalScoring::model_;

// Done-when of issue 73: a file written by a script, not by the detector,
// scores as the project's own run over the same detections: every metric
// but those of the detector's own stages (protocol A's maxima, the funnel's
// stages, the time per stage); report, regress and history take the run.
TEST_F(ExternalScoring, AScriptsFileScoresAsTheProjectsOwnRun) {
  const std::string own = dir_ + "/own.jsonl", rewritten = dir_ + "/rewritten";
  const testing::CommandResult run = Workbench("evaluate --quiet --split all --model " + model_ +
                                               " --db " + db_ + " --write-detections " + own);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::map<std::string, double> expected = LatestMetrics(db_);
  const testing::CommandResult script = testing::RunCommand(
      "/usr/bin/python3 " FURN_SOURCE_DIR "/tests/workbench/scripts/rewrite_detections.py " + own +
      " " + rewritten);
  ASSERT_EQ(script.exit_code, 0) << script.output;
  ASSERT_EQ(std::distance(std::filesystem::directory_iterator(rewritten),
                          std::filesystem::directory_iterator()),
            8);  // one file per frame
  const testing::CommandResult scored = Workbench("evaluate --split all --db " + db_ +
                                                  " --detections " + rewritten + " --label script");
  ASSERT_EQ(scored.exit_code, 0) << scored.output;
  EXPECT_NE(scored.output.find("AP3D@0.25"), std::string::npos) << scored.output;
  const std::map<std::string, double> got = LatestMetrics(db_);
  int compared = 0;
  for (const auto& [name, value] : expected) {
    const bool stages = name.rfind("paper/", 0) == 0 || name.rfind("funnel/", 0) == 0 ||
                        (name.rfind("latency_", 0) == 0 &&
                         name.find("_p50_ms") != std::string::npos && name != "latency_p50_ms");
    if (stages) continue;
    ASSERT_EQ(got.count(name), 1u) << name;
    if (std::isnan(value)) {
      EXPECT_TRUE(std::isnan(got.at(name))) << name;
    } else {
      // Doubles travel as shortest round-trip text; yaw passes through the
      // REP 103 convention and back (1e-15 rad).
      EXPECT_NEAR(got.at(name), value, 1e-9 * std::max(1.0, std::abs(value))) << name;
    }
    ++compared;
  }
  EXPECT_GT(compared, 60);
  EXPECT_EQ(got.count("paper/chair/best_f1"), 0u);  // no Hough maxima to sweep

  // The run is a run like any other: its report (gallery from the file),
  // regress against the model's run, history beside it.
  const testing::CommandResult report =
      Workbench("report --db " + db_ + " --out " + dir_ + "/report-script");
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const std::string html = ReadFileBytes(dir_ + "/report-script/index.html");
  EXPECT_NE(html.find("rewritten"), std::string::npos);
  EXPECT_NE(html.find("scene.html"), std::string::npos);  // its gallery's 3-D pages
  DatasetDb dataset(db_, DatasetDb::Mode::kReadOnly);
  const std::vector<RunRecord> runs = dataset.Runs();
  EXPECT_EQ(runs.back().kind, "external");
  // The model's run against the script's as the baseline: every metric the
  // script's run has, the model's has too, no worse.
  const testing::CommandResult regress =
      Workbench("regress --db " + db_ + " --run " + std::to_string(runs[runs.size() - 2].id) +
                " --baseline " + std::to_string(runs.back().id) + " --tolerance 1e-6");
  EXPECT_EQ(regress.exit_code, 0) << regress.output;
  EXPECT_EQ(Workbench("history --db " + db_ + " --out " + dir_ + "/history").exit_code, 0);
}

TEST_F(ExternalScoring, AFileMissingAFrameOrNamingAnotherDatasetsIsRefused) {
  const std::string own = dir_ + "/refused.jsonl";
  ASSERT_EQ(Workbench("evaluate --quiet --split all --model " + model_ + " --db " + db_ +
                      " --write-detections " + own)
                .exit_code,
            0);
  std::string text = ReadFileBytes(own);
  const std::string first_line = text.substr(0, text.find('\n') + 1);
  testing::WriteText(dir_ + "/short.jsonl", text.substr(first_line.size()));
  const testing::CommandResult missing =
      Workbench("evaluate --split all --db " + db_ + " --detections " + dir_ + "/short.jsonl");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.output.find("short.jsonl: has no line for frame 0"), std::string::npos)
      << missing.output;
  std::string foreign = first_line;
  foreign.replace(foreign.find("\"frame\":0"), 9, "\"frame\":999");
  testing::WriteText(dir_ + "/foreign.jsonl", text + foreign);
  const testing::CommandResult other =
      Workbench("evaluate --split all --db " + db_ + " --detections " + dir_ + "/foreign.jsonl");
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_NE(other.output.find("foreign.jsonl:9: \"frame\" 999 is not a frame of"),
            std::string::npos)
      << other.output;
  EXPECT_NE(Workbench("evaluate --db " + db_ + " --model " + model_ + " --detections " + own)
                .output.find("no --model"),
            std::string::npos);
}

// The worked example of docs/evaluation.md: the png export, the example
// detector in Python over it, scored; the export's frames.json read by
// that script (NumPy, Pillow) and here by nlohmann.
TEST_F(ExternalScoring, TheExampleDetectorOverThePngExportIsScored) {
  const std::string out = dir_ + "/png";
  ASSERT_EQ(Workbench("dataset export " + db_ + " --format png --out " + out).exit_code, 0);
  const nlohmann::json index = nlohmann::json::parse(ReadFileBytes(out + "/frames.json"));
  EXPECT_EQ(index["format"], "furnidet-png-export");
  ASSERT_EQ(index["frames"].size(), 8u);
  DatasetDb dataset(db_, DatasetDb::Mode::kReadOnly);
  for (const nlohmann::json& frame : index["frames"]) {
    const int64_t id = frame["frame"];
    const RoomRecord room = dataset.ReadRoom(*dataset.RoomOfFrame(id), false);
    const FrameRecord* record = nullptr;
    for (const FrameRecord& f : room.frames) {
      if (f.id == id) record = &f;
    }
    ASSERT_NE(record, nullptr);
    for (int r = 0; r < 4; ++r) {  // the documented four rows
      for (int c = 0; c < 4; ++c)
        EXPECT_EQ(frame["world_from_camera"][r][c].get<double>(),
                  record->world_from_camera.matrix()(r, c));
    }
    EXPECT_EQ(frame["objects"].size(), room.objects.size());
    EXPECT_TRUE(std::filesystem::exists(out + "/" + frame["depth"].get<std::string>()));
  }
  const std::string detections = dir_ + "/heights.jsonl";
  const testing::CommandResult example =
      testing::RunCommand("/usr/bin/python3 " FURN_SOURCE_DIR "/examples/external_detector.py " +
                          out + " --out " + detections);
  ASSERT_EQ(example.exit_code, 0) << example.output;
  const testing::CommandResult scored = Workbench(
      "evaluate --split all --db " + db_ + " --detections " + detections + " --label heights");
  ASSERT_EQ(scored.exit_code, 0) << scored.output;
  const std::map<std::string, double> metrics = LatestMetrics(db_);
  EXPECT_GE(metrics.at("mAP@10cm"), 0.0);
  EXPECT_LE(metrics.at("mAP@10cm"), 1.0);
  EXPECT_EQ(metrics.at("frames"), 8);
  EXPECT_EQ(metrics.count("latency_p50_ms"), 1u);  // the script gave its times
}

// The pcd export read by PCL (not by the workbench's reader): world points
// with the camera's pose as VIEWPOINT, each point's instance id as label,
// and the labels file beside it.
TEST_F(ExternalScoring, ThePcdExportKeepsPoseAndLabels) {
  const std::string out = dir_ + "/pcd";
  ASSERT_EQ(Workbench("dataset export " + db_ + " --format pcd --out " + out).exit_code, 0);
  DatasetDb dataset(db_, DatasetDb::Mode::kReadOnly);
  const RoomRecord room = dataset.ReadRoom(dataset.RoomIds().front(), /*with_images=*/false);
  const FrameRecord& frame = room.frames.front();
  char stem[16];
  std::snprintf(stem, sizeof(stem), "%06lld", static_cast<long long>(frame.id));
  pcl::PointCloud<pcl::PointXYZL> cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(out + "/" + stem + ".pcd", cloud), 0);
  EXPECT_EQ(cloud.width, 640u);
  EXPECT_EQ(cloud.height, 480u);
  EXPECT_TRUE(cloud.sensor_origin_.head<3>().isApprox(
      frame.world_from_camera.translation().cast<float>(), 1e-5f));
  EXPECT_TRUE(cloud.sensor_orientation_.toRotationMatrix().isApprox(
      frame.world_from_camera.linear().cast<float>(), 1e-5f));
  std::map<uint32_t, int> labelled;
  int floor = 0, finite = 0;
  for (const pcl::PointXYZL& p : cloud) {
    if (!std::isfinite(p.z)) continue;
    ++finite;
    floor += std::abs(p.z) < 0.03f;  // world: the floor at z = 0
    ++labelled[p.label];
  }
  EXPECT_GT(floor, finite / 20);
  const nlohmann::json labels = nlohmann::json::parse(ReadFileBytes(out + "/" + stem + ".json"));
  EXPECT_EQ(labels["format"], "furnidet-pcd-labels");
  std::set<uint32_t> known = {0,
                              labels["structure_labels"]["floor"].get<uint32_t>(),
                              labels["structure_labels"]["wall"].get<uint32_t>()};
  for (const nlohmann::json& object : labels["objects"])
    known.insert(object["label"].get<uint32_t>());
  for (const auto& [label, count] : labelled) EXPECT_TRUE(known.count(label)) << label;
  for (const FrameObjectRecord& seen : frame.objects) {
    if (seen.visible_pixels > 200) {
      EXPECT_GT(labelled[seen.instance_id], 0) << seen.instance_id;
    }
  }
  // The workbench detects in it with the pose the VIEWPOINT gives.
  const testing::CommandResult detect = Workbench("detect --quiet --floor-aligned --model " +
                                                  model_ + " --cloud " + out + "/" + stem + ".pcd");
  EXPECT_EQ(detect.exit_code, 0) << detect.output;
}

}  // namespace
}  // namespace furn
