// The 3-D page's data on a hand-made run whose answers are known; the page
// itself is opened in Chromium by the evaluate and train tests.
#include "reports/scene_view.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/util/file_util.h"
#include "tests/test_util.h"

namespace furn {
namespace {

nlohmann::json SceneData(const std::string& dir) {
  const std::string text = ReadFileBytes(dir + "/scene_data.js");
  EXPECT_EQ(text.rfind("window.FURN_SCENE = ", 0), 0u);
  return nlohmann::json::parse(text.substr(20, text.size() - 22));
}

DetectionResult TwoChairsOneFound() {
  DetectionResult result;
  result.world_from_camera.translation() << 0, -2, 1;
  for (int k = 0; k < 200001; ++k)  // more than a page carries
    result.debug.points.emplace_back(0.00001f * k, 1.0f, 0.5f);
  result.debug.segment_of_point.assign(result.debug.points.size(), 3);
  Detection found;
  found.furniture_class = FurnitureClass::kChair;
  found.x = 0.02;
  found.y = 1.0;
  found.width = found.depth = 0.5;
  found.score = 0.8;
  found.model_name = "evil</script><!--";
  result.detections = {found};
  DetectionDebug::Hypothesis near_second;  // a chair maximum near the missed chair
  near_second.furniture_class = FurnitureClass::kChair;
  near_second.x = 2.05;
  near_second.y = 1.0;
  near_second.outcome = HypothesisOutcome::kLowCoverage;
  result.debug.hypotheses = {near_second};
  return result;
}

TEST(SceneView, FatesAndBoxesFollowTheEvaluationsRules) {
  const std::string dir = testing::ScratchDir();
  std::vector<GroundTruthFootprint> truth(3);
  for (GroundTruthFootprint& t : truth) {
    t.furniture_class = FurnitureClass::kChair;
    t.width = 0.5;
    t.depth = 0.6;
    t.height = 0.9;
    t.y = 1.0;
    t.visibility = 0.9;
  }
  truth[1].x = 2.0;
  truth[2].x = 4.0;
  truth[2].visibility = 0.1;  // barely visible: no target
  SceneViewLinks links;
  links.title = "frame <7>";
  links.next = "../8/scene.html";
  WriteSceneView(
      TwoChairsOneFound(), TrainedModel{}, CameraIntrinsics::KinectV1(), truth, dir, links);
  const nlohmann::json scene = SceneData(dir);
  EXPECT_EQ(scene["truth"][0]["fate"], "found (score 0.80, 2 cm off)");
  EXPECT_EQ(scene["truth"][1]["fate"], "missed: lost at low coverage");
  EXPECT_TRUE(scene["truth"][1]["missed"].get<bool>());
  EXPECT_FALSE(scene["truth"][2]["target"].get<bool>());
  EXPECT_EQ(scene["detections"][0]["fate"], "true detection, 2 cm off");
  // REP 103 boxes: the footprint 0.5 across the front, 0.6 front to back.
  EXPECT_EQ(scene["truth"][0]["size"], nlohmann::json({0.6, 0.5, 0.9}));
  EXPECT_NEAR(scene["truth"][0]["centre"][2].get<double>(), 0.45, 1e-12);
  EXPECT_EQ(scene["navigation"]["next"], "../8/scene.html");
  EXPECT_TRUE(scene["heat"].is_null());  // a codebook run
  // 200 001 points: every second one, below the cap; their segments kept.
  EXPECT_EQ(scene["points"]["stride"], 2);
  EXPECT_EQ(scene["points"]["count"], 100001);
  EXPECT_FALSE(scene["points"]["segment"].is_null());
  EXPECT_LE(ReadFileBytes(dir + "/scene_data.js").size(), 2u << 20);
  // Text from files someone else wrote never ends the script or the title.
  EXPECT_EQ(ReadFileBytes(dir + "/scene_data.js").find('<'), std::string::npos);
  EXPECT_EQ(scene["detections"][0]["model"], "evil</script><!--");
  const std::string page = ReadFileBytes(dir + "/scene.html");
  EXPECT_NE(page.find("<title>frame &lt;7&gt;</title>"), std::string::npos);
  EXPECT_NE(page.find("<script src=\"three/three.min.js\">"), std::string::npos);
  EXPECT_NE(ReadFileBytes(dir + "/three/VERSION").find("three.js r"), std::string::npos);
  EXPECT_GT(ReadFileBytes(dir + "/three/three.min.js").size(), 500000u);
}

TEST(SceneView, AReportSharesOneLibraryFolder) {
  const std::string dir = testing::ScratchDir();
  SceneViewLinks links;
  links.library = "../../three";
  WriteSceneView(TwoChairsOneFound(),
                 TrainedModel{},
                 CameraIntrinsics::KinectV1(),
                 {},
                 dir + "/frames/1",
                 links);
  EXPECT_FALSE(std::filesystem::exists(dir + "/frames/1/three"));
  EXPECT_NE(ReadFileBytes(dir + "/frames/1/scene.html").find("src=\"../../three/scene_viewer.js\""),
            std::string::npos);
  const nlohmann::json scene = SceneData(dir + "/frames/1");
  EXPECT_EQ(scene["detections"][0]["fate"], "no ground truth here");
  WriteSceneLibrary(dir + "/three");
  for (const char* file : {"three.min.js", "OrbitControls.js", "scene_viewer.js", "VERSION"})
    EXPECT_TRUE(std::filesystem::is_regular_file(dir + "/three/" + file)) << file;
}

}  // namespace
}  // namespace furn
