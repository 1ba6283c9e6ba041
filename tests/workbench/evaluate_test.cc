// generate -> train -> evaluate -> regress through the CLI on a small
// procedural dataset; the run is gated by the committed baseline
// tests/baselines/small_eval.json (the CI evaluation).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <vector>

#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "db/sqlite.h"
#include "tests/test_util.h"
#include "tests/workbench/dataset_dump.h"
#include "tests/workbench/workbench_commands.h"
#include "workbench/formats/depth_png.h"
#include "workbench/pipelines/evaluate.h"

namespace furn {
namespace {

testing::CommandResult Workbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
}

// The first gallery frame's 3-D page, opened in Chromium: as many boxes and
// points as its data (and true boxes as the room has objects), every layer
// hides when toggled, a click on a detection names it, no error, and the
// neighbouring frame and the report are linked.
void CheckGalleryScene(const std::string& report, const std::string& db) {
  const std::string html = ReadFileBytes(report + "/index.html");
  const size_t end = html.find("/scene.html\">look around in 3-D");
  ASSERT_NE(end, std::string::npos) << "no 3-D link in the gallery";
  const size_t start = html.rfind("\"", end) + 1;
  const std::string frame_dir = report + "/" + html.substr(start, end - start);
  std::string data = ReadFileBytes(frame_dir + "/scene_data.js");
  ASSERT_EQ(data.rfind("window.FURN_SCENE = ", 0), 0u);
  const nlohmann::json scene = nlohmann::json::parse(data.substr(20, data.size() - 22));
  EXPECT_TRUE(std::filesystem::exists(report + "/three/three.min.js"));
  EXPECT_FALSE(std::filesystem::exists(frame_dir + "/three"));  // one copy per report
  EXPECT_EQ(scene["navigation"]["index"], "../../index.html");
  const std::string next = scene["navigation"]["next"];
  if (!next.empty()) {
    EXPECT_TRUE(std::filesystem::exists(frame_dir + "/" + next)) << next;
  }
  {
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    const int64_t frame = std::stoll(std::filesystem::path(frame_dir).filename().string());
    EXPECT_EQ(scene["truth"].size(),
              dataset.ReadRoom(*dataset.RoomOfFrame(frame), false).objects.size());
  }
  std::string output;
  const std::string text = testing::SceneSelfTest(frame_dir + "/scene.html", &output);
  ASSERT_FALSE(text.empty()) << output;
  const nlohmann::json check = nlohmann::json::parse(text);
  EXPECT_TRUE(check["webgl"].get<bool>());
  EXPECT_EQ(check["errors"].size(), 0u) << text;
  EXPECT_EQ(check["counts"]["points"], scene["points"]["count"]);
  EXPECT_GT(check["counts"]["points"].get<int>(), 1000);
  EXPECT_EQ(check["objects"]["truth"].get<size_t>(), scene["truth"].size());
  EXPECT_EQ(check["objects"]["detections"].get<size_t>(), scene["detections"].size());
  EXPECT_EQ(check["objects"]["maxima"].get<size_t>(), scene["maxima"].size());
  for (const auto& [layer, hid] : check["toggles"].items()) EXPECT_TRUE(hid.get<bool>()) << layer;
  EXPECT_LT(check["drawn"]["without_points"], check["drawn"]["all"]);
  EXPECT_LT(check["drawn"]["without_truth"], check["drawn"]["all"]);
  if (!scene["detections"].empty()) {
    EXPECT_EQ(check["pick"].get<std::string>().rfind(
                  "detection: " + scene["detections"][0]["class"].get<std::string>(), 0),
              0u)
        << check["pick"];
  }
  std::printf("scene page %s: %d points, loaded in %d ms (virtual time)\n",
              frame_dir.c_str(),
              check["counts"]["points"].get<int>(),
              check["load_ms"].get<int>());
}

// A 640 x 480 camera 0.25 m above the floor looking along world +x; its
// image's side at 2 m lies 2 * 320 / 580 = 1.103 m to the left (+y).
TEST(Evaluate, ShareInViewIsThePartOfTheBoxInsideTheImage) {
  FrameRecord frame;
  frame.width = 640;
  frame.height = 480;
  frame.fx = frame.fy = 580;
  frame.cx = 319.5;
  frame.cy = 239.5;
  Eigen::Matrix3d world_from_camera;  // camera x right = world -y, y down = -z, z ahead = +x
  world_from_camera << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  frame.world_from_camera.linear() = world_from_camera;
  frame.world_from_camera.translation() = Eigen::Vector3d(0, 0, 0.25);
  ObjectRecord table;
  table.x = 2;
  table.width = 1.0;  // along its own x: turned by yaw = 90 deg, along world y
  table.depth = 0.2;
  table.height = 0.5;
  table.yaw = M_PI / 2;
  EXPECT_DOUBLE_EQ(ShareInView(table, frame), 1.0);
  table.y = 1.103;  // centred on the image's side: half of it beyond
  EXPECT_NEAR(ShareInView(table, frame), 0.5, 0.07);
  table.y = 2.5;  // wholly beyond the side
  EXPECT_DOUBLE_EQ(ShareInView(table, frame), 0.0);
  table.y = 0;
  table.x = -2;  // behind the camera
  EXPECT_DOUBLE_EQ(ShareInView(table, frame), 0.0);
}

TEST(Evaluate, SmallRunIsStoredAndGatedByTheCommittedBaseline) {
  const std::string dir = testing::ScratchDir();
  const std::string db = dir + "/small.db", model = dir + "/small.fcm";
  ASSERT_EQ(
      Workbench("generate --catalog procedural:4 --rooms 4 --frames 2 --seed 5 --quiet --out " + db)
          .exit_code,
      0);
  ASSERT_EQ(Workbench(std::string(testing::kTrainSmallCodebook) + model).exit_code, 0);
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
    CheckGalleryScene(report, db);
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

// A small dataset and a model trained on its catalog, shared by the edge
// cases below (ctest runs each TEST in its own process, so they are one TEST
// with a section each); each section works on its own copy of the dataset.
struct SmallDatasetAndModel {
  std::string dir, model;

  std::string CopyOfDataset(const std::string& name) const {
    const std::string copy = dir + "/" + name + ".db";
    std::filesystem::copy_file(
        dir + "/base.db", copy, std::filesystem::copy_options::overwrite_existing);
    return copy;
  }
};

std::map<std::string, double> LastRunMetrics(const std::string& db) {
  DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
  return dataset.RunMetrics(dataset.Runs().back().id);
}

void MissingDatasetIsOneLineAndCreatesNothing(const SmallDatasetAndModel& data) {
  const std::string missing = data.dir + "/typo.db";
  const testing::CommandResult run =
      Workbench("evaluate --quiet --split all --model " + data.model + " --db " + missing);
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find(missing + ": no such dataset file"), std::string::npos) << run.output;
  EXPECT_EQ(std::count(run.output.begin(), run.output.end(), '\n'), 1) << run.output;
  for (const char* suffix : {"", "-wal", "-shm", "-journal"})
    EXPECT_FALSE(std::filesystem::exists(missing + suffix)) << suffix;
  // The same for the commands that read a dataset's runs.
  EXPECT_EQ(Workbench("report --db " + missing + " --out " + data.dir + "/r").exit_code, 1);
  EXPECT_FALSE(std::filesystem::exists(missing));
}

// A frame with no point in range (a camera against a wall, a dead sensor) is
// a frame without detections: the run completes and its objects are missed.
void FrameWithNoPointInRangeIsAFrameWithoutDetections(const SmallDatasetAndModel& data) {
  const std::string db = data.CopyOfDataset("blank");
  int64_t blank_frame = 0;
  {
    Database database(db, Database::Mode::kReadWriteExisting);
    Statement first(&database, "SELECT id, width, height FROM frames ORDER BY id LIMIT 1");
    ASSERT_TRUE(first.Step());
    blank_frame = first.ColumnInt(0);
    DepthFrame nothing;
    nothing.Reshape(static_cast<int>(first.ColumnInt(1)), static_cast<int>(first.ColumnInt(2)));
    std::fill(nothing.depth.begin(), nothing.depth.end(), 0.0f);
    Statement blank(&database, "UPDATE frames SET depth_noisy_png = ? WHERE id = ?");
    blank.BindBlob(1, EncodeDepthPng(nothing)).Bind(2, blank_frame).Run();
  }
  const testing::CommandResult run =
      Workbench("evaluate --split all --model " + data.model + " --db " + db);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("1 frames had no point in range"), std::string::npos) << run.output;
  const std::map<std::string, double> metrics = LastRunMetrics(db);
  EXPECT_EQ(metrics.at("frames"), 4);
  EXPECT_EQ(metrics.at("frames_without_points"), 1);
  DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
  const RunRecord run_record = dataset.Runs().back();
  Statement detections(dataset.database(),
                       "SELECT count(*) FROM run_detections WHERE run_id = ? AND frame_id = ?");
  detections.Bind(1, run_record.id).Bind(2, blank_frame);
  ASSERT_TRUE(detections.Step());
  EXPECT_EQ(detections.ColumnInt(0), 0);
  // Its visible objects are counted as missed at 10 cm.
  const nlohmann::json errors = nlohmann::json::parse(run_record.results_json)
                                    .at("frame_errors")
                                    .at(std::to_string(blank_frame));
  EXPECT_EQ(errors[0].get<int>(), 0);  // no false positives
  EXPECT_GT(errors[1].get<int>(), 0);  // missed objects
}

// Which CAD models are "seen" is what the model file was trained on, not the
// dataset's evaluation_only flags (its rooms may come from other catalogs).
// The metrics of an evaluation of a copy of the dataset changed by `sql`
// (empty when the evaluation fails, which the caller's assertions then show).
std::map<std::string, double> MetricsOfChangedCopy(const SmallDatasetAndModel& data,
                                                   const std::string& name,
                                                   const std::vector<std::string>& sql) {
  const std::string db = data.CopyOfDataset(name);
  {
    Database database(db, Database::Mode::kReadWriteExisting);
    for (const std::string& statement : sql) database.Execute(statement);
  }
  const testing::CommandResult run =
      Workbench("evaluate --quiet --split all --model " + data.model + " --db " + db);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  return run.exit_code == 0 ? LastRunMetrics(db) : std::map<std::string, double>{};
}

void SeenModelsAreThoseTheModelWasTrainedOn(const SmallDatasetAndModel& data) {
  // Every model flagged evaluation-only, yet the model file was trained on all of them.
  const std::map<std::string, double> seen =
      MetricsOfChangedCopy(data, "flagged", {"UPDATE models SET evaluation_only = 1"});
  ASSERT_TRUE(seen.count("mAP_seen@10cm"));
  EXPECT_DOUBLE_EQ(seen.at("mAP_seen@10cm"), seen.at("mAP@10cm"));
  EXPECT_FALSE(seen.count("mAP_unseen@10cm"));
  EXPECT_TRUE(seen.count("cad_identified"));

  // The same rooms under other model ids: nothing was seen in training.
  const std::map<std::string, double> unseen =
      MetricsOfChangedCopy(data,
                           "renamed",
                           {"PRAGMA foreign_keys = OFF",
                            "UPDATE models SET id = 'other/' || id, evaluation_only = 0",
                            "UPDATE objects SET model_id = 'other/' || model_id"});
  ASSERT_TRUE(unseen.count("mAP_unseen@10cm"));
  EXPECT_DOUBLE_EQ(unseen.at("mAP_unseen@10cm"), unseen.at("mAP@10cm"));
  EXPECT_FALSE(unseen.count("mAP_seen@10cm"));
  EXPECT_FALSE(unseen.count("cad_identified"));  // no true model to identify
}

// A frame's finite points.
size_t FinitePoints(const DetectionInput& input) {
  return static_cast<size_t>(std::count_if(input.points.begin(),
                                           input.points.end(),
                                           [](const Eigen::Vector3f& p) { return p.allFinite(); }));
}

// The run's detections as text, in order (score and place to the bit).
std::string DetectionsOfRun(const std::string& db, int64_t run_id) {
  Database database(db, Database::Mode::kReadOnly);
  Statement rows(&database,
                 "SELECT frame_id, class, x, y, score FROM run_detections WHERE run_id = ? "
                 "ORDER BY rowid");
  rows.Bind(1, run_id);
  std::string text;
  while (rows.Step()) {
    char line[160];
    std::snprintf(line,
                  sizeof(line),
                  "%lld %s %a %a %a\n",
                  static_cast<long long>(rows.ColumnInt(0)),
                  rows.ColumnText(1).c_str(),
                  rows.ColumnDouble(2),
                  rows.ColumnDouble(3),
                  rows.ColumnDouble(4));
    text += line;
  }
  return text;
}

// Issue 37: each frame with its room's other frames fused in, seen from its
// own camera; the pose error is the same on every run; bad spreads are one
// line and store nothing; detect shows a fused frame.
void FusedRoomFramesAreOneInputAndAStoredOption(const SmallDatasetAndModel& data) {
  const std::string db = data.CopyOfDataset("fused");
  {
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    const RoomRecord room = dataset.ReadRoom(dataset.RoomIds().at(0), /*with_images=*/true);
    ASSERT_EQ(room.frames.size(), 2u);
    const FrameRecord& frame = room.frames[1];
    const DetectionInput plain = RoomFrameInput(room, frame, FrameFusion{}, false, db);
    EXPECT_EQ(plain.width, 640);
    FrameFusion fusion;
    fusion.room_frames = true;
    const DetectionInput fused = RoomFrameInput(room, frame, fusion, false, db);
    EXPECT_EQ(fused.width, 0);
    EXPECT_EQ(fused.points.size(),
              FinitePoints(plain) + FinitePoints(DetectionInputOf(room.frames[0], "frame 0")));
    EXPECT_TRUE(fused.world_from_camera->isApprox(frame.world_from_camera));
    fusion.pose_noise_m = 0.05;
    fusion.pose_noise_deg = 2;
    const DetectionInput noisy = RoomFrameInput(room, frame, fusion, false, db);
    ASSERT_EQ(noisy.points.size(), fused.points.size());
    EXPECT_NE(noisy.points.front(), fused.points.front());  // the frame itself comes last ...
    EXPECT_EQ(noisy.points.back(), fused.points.back());    // ... and keeps its pose
    EXPECT_EQ(RoomFrameInput(room, frame, fusion, false, db).points, noisy.points);
    // A planar error moves the other frame's points along the floor only.
    fusion.planar_noise = true;
    const DetectionInput level = RoomFrameInput(room, frame, fusion, false, db);
    const Eigen::Vector3f world_level = frame.world_from_camera.cast<float>() * level.points[0];
    const Eigen::Vector3f world_exact = frame.world_from_camera.cast<float>() * fused.points[0];
    EXPECT_GT((world_level - world_exact).head<2>().norm(), 1e-3);
    EXPECT_NEAR(world_level.z(), world_exact.z(), 1e-4);
    fusion.planar_noise = false;
    EXPECT_NE(testing::ErrorOf([&] {
                RoomFrameInput(room, frame, fusion, true, db);
              }).find("its floor is estimated"),
              std::string::npos);
  }
  const std::string evaluate =
      "evaluate --quiet --split all --model " + data.model + " --db " + db + " --fuse-room-frames";
  ASSERT_EQ(Workbench(evaluate).exit_code, 0);
  for (int k = 0; k < 2; ++k)  // the error drawn and registered away alike every time
    ASSERT_EQ(Workbench(evaluate + " --fuse-pose-noise 0.05,2 --fuse-register").exit_code, 0);
  ASSERT_EQ(Workbench(evaluate + " --fuse-pose-noise 0.03,2,planar --fuse-register --fuse-planar")
                .exit_code,
            0);
  {
    DatasetDb dataset(db, DatasetDb::Mode::kReadOnly);
    const std::vector<RunRecord> runs = dataset.Runs();
    ASSERT_EQ(runs.size(), 4u);
    const nlohmann::json stored = nlohmann::json::parse(runs[1].options_json).at("fusion");
    EXPECT_TRUE(stored.at("room_frames").get<bool>());
    EXPECT_EQ(stored.at("pose_noise_m").get<double>(), 0.05);
    EXPECT_EQ(stored.at("pose_noise_deg").get<double>(), 2);
    EXPECT_TRUE(stored.at("register").get<bool>());
    EXPECT_FALSE(
        nlohmann::json::parse(runs[0].options_json).at("fusion").at("register").get<bool>());
    EXPECT_EQ(dataset.RunMetrics(runs[0].id).at("frames"), 4);
    EXPECT_FALSE(DetectionsOfRun(db, runs[1].id).empty());
    EXPECT_EQ(DetectionsOfRun(db, runs[1].id), DetectionsOfRun(db, runs[2].id));
    EXPECT_FALSE(stored.contains("planar")) << "runs stored before planar read the same";
    const nlohmann::json level = nlohmann::json::parse(runs[3].options_json).at("fusion");
    EXPECT_TRUE(level.at("planar_noise").get<bool>());
    EXPECT_TRUE(level.at("planar").get<bool>());
    EXPECT_EQ(FrameFusion::FromJson(level, "run 4").Json(), level);
  }
  for (const auto& [flags, expected] : std::vector<std::pair<std::string, std::string>>{
           {"--fuse-room-frames --fuse-pose-noise 0.05", "'0.05' must be M,DEG"},
           {"--fuse-room-frames --fuse-pose-noise 0.05,x", "'0.05,x' must be M,DEG"},
           {"--fuse-room-frames --fuse-pose-noise 0.05,2,level", "must be M,DEG or M,DEG,planar"},
           {"--fuse-room-frames --fuse-planar", "--fuse-planar applies to --fuse-register"},
           {"--fuse-room-frames --fuse-pose-noise=-1,2", "-1 m must be in 0..1 m"},
           {"--fuse-room-frames --fuse-pose-noise 0,90", "90 degrees must be in 0..45"},
           {"--fuse-pose-noise 0.02,1", "applies to fused frames"},
           {"--fuse-register", "--fuse-register applies to fused frames"}}) {
    const testing::CommandResult bad = Workbench("evaluate --quiet --split all --model " +
                                                 data.model + " --db " + db + " " + flags);
    EXPECT_NE(bad.exit_code, 0) << flags;
    EXPECT_NE(bad.output.find(expected), std::string::npos) << flags << ": " << bad.output;
    EXPECT_EQ(std::count(bad.output.begin(), bad.output.end(), '\n'), 1) << bad.output;
  }
  EXPECT_EQ(DatasetDb(db, DatasetDb::Mode::kReadOnly).Runs().size(), 4u);  // nothing stored
  // crossval refuses it before training a fold.
  const testing::CommandResult crossval = Workbench("crossval --quiet --db " + db + " --work-dir " +
                                                    data.dir + "/folds --fuse-register");
  EXPECT_NE(crossval.exit_code, 0);
  EXPECT_NE(crossval.output.find("--fuse-register applies to fused frames"), std::string::npos)
      << crossval.output;
  EXPECT_FALSE(std::filesystem::exists(data.dir + "/folds"));
  const testing::CommandResult shown =
      Workbench("detect --quiet --model " + data.model + " --db " + db +
                " --frame 1 --fuse --out " + data.dir + "/fused.json");
  ASSERT_EQ(shown.exit_code, 0) << shown.output;
  EXPECT_NE(ReadFileBytes(data.dir + "/fused.json").find("with its room's 1 other frames fused"),
            std::string::npos);
}

TEST(Evaluate, EmptyFramesMissingDatasetsAndSeenModels) {
  SmallDatasetAndModel data;
  data.dir = testing::ScratchDir();
  data.model = data.dir + "/model.fcm";
  ASSERT_EQ(Workbench("generate --catalog procedural:4 --rooms 2 --frames 2 --seed 5 --quiet "
                      "--out " +
                      data.dir + "/base.db")
                .exit_code,
            0);
  ASSERT_EQ(Workbench(std::string(testing::kTrainSmallCodebook) + data.model).exit_code, 0);
  {
    SCOPED_TRACE("missing dataset");
    MissingDatasetIsOneLineAndCreatesNothing(data);
  }
  {
    SCOPED_TRACE("frame with no point in range");
    FrameWithNoPointInRangeIsAFrameWithoutDetections(data);
  }
  {
    SCOPED_TRACE("seen models");
    SeenModelsAreThoseTheModelWasTrainedOn(data);
  }
  {
    SCOPED_TRACE("fused room frames");
    FusedRoomFramesAreOneInputAndAStoredOption(data);
  }
}

// Issue 31 without a cluster: `evaluate --shards 3 --emit-only` writes the
// array job's scripts; run by hand as Slurm would run them (each task with
// its SLURM_ARRAY_TASK_ID, then the final script), they store the run one
// process stores, timings aside. A missing or foreign shard is one line.
TEST(Evaluate, ShardsRunFromTheJobScriptsMergeIntoTheOneProcessRun) {
  const std::string dir = testing::ScratchDir();
  const std::string one = dir + "/one.db", sharded = dir + "/sharded.db", model = dir + "/m.fcm";
  ASSERT_EQ(
      Workbench("generate --catalog procedural:4 --rooms 4 --frames 2 --seed 5 --quiet --out " +
                one)
          .exit_code,
      0);
  std::filesystem::copy_file(one, sharded);
  ASSERT_EQ(Workbench(std::string(testing::kTrainSmallCodebook) + model).exit_code, 0);
  const std::string evaluate = "evaluate --quiet --split all --model " + model + " --db ";
  ASSERT_EQ(Workbench(evaluate + one).exit_code, 0);
  const std::string job = dir + "/job";
  const testing::CommandResult emit =
      Workbench(evaluate + sharded + " --shards 3 --emit-only --job-dir " + job);
  ASSERT_EQ(emit.exit_code, 0) << emit.output;
  EXPECT_NE(emit.output.find("--array=0,1,2"), std::string::npos) << emit.output;
  for (int k = 0; k < 3; ++k) {
    const testing::CommandResult task = testing::RunCommand(
        "SLURM_ARRAY_TASK_ID=" + std::to_string(k) + " bash " + job + "/task.sbatch");
    ASSERT_EQ(task.exit_code, 0) << task.output;
    EXPECT_TRUE(std::filesystem::exists(job + "/status/task-" + std::to_string(k) + ".ok"));
  }
  const testing::CommandResult merged = testing::RunCommand("bash " + job + "/final.sbatch");
  ASSERT_EQ(merged.exit_code, 0) << merged.output;
  EXPECT_NE(merged.output.find("merged 3 shards"), std::string::npos) << merged.output;
  const std::string runs = testing::DumpRuns(one);
  EXPECT_GT(runs.size(), 1000u);
  EXPECT_EQ(testing::DumpRuns(sharded), runs);
  const testing::CommandResult done =
      Workbench(evaluate + sharded + " --shards 3 --emit-only --job-dir " + job);
  EXPECT_NE(done.output.find("nothing: every task and the final step are done"), std::string::npos)
      << done.output;

  // Shards that are not this evaluation's: one line, exit 1, no run stored.
  auto shard = [&](int k) { return " " + job + "/shard-" + std::to_string(k) + ".json"; };
  auto refused = [&](const std::string& arguments, const std::string& why) {
    const testing::CommandResult bad = Workbench(evaluate + sharded + arguments);
    EXPECT_EQ(bad.exit_code, 1) << arguments;
    EXPECT_NE(bad.output.find(why), std::string::npos) << bad.output;
    EXPECT_EQ(std::count(bad.output.begin(), bad.output.end(), '\n'), 1) << bad.output;
  };
  refused(" --merge-shards" + shard(0) + shard(1), "is shard 0/3, expected 0/2");
  refused(" --merge-shards" + shard(0) + shard(2) + shard(1), "is shard 2/3, expected 1/3");
  refused(" --min-score 0.5 --merge-shards" + shard(0) + shard(1) + shard(2),
          "was evaluated with other options");
  refused(" --max-frames 6 --merge-shards" + shard(0) + shard(1) + shard(2),
          "was evaluated on other frames");
  std::filesystem::rename(job + "/shard-1.json", dir + "/moved.json");
  refused(" --merge-shards" + shard(0) + shard(1) + shard(2), "missing: shard 1 of 3");
  refused(" --shard 1/3", "--shard i/N and --shard-out go together");
  DatasetDb dataset(sharded, DatasetDb::Mode::kReadOnly);
  EXPECT_EQ(dataset.Runs().size(), 1u);
}

}  // namespace
}  // namespace furn
