// The debug folder's PNGs, as the report's gallery lists them: what the
// writer made, every class's vote map included (a sofa's was left out of a
// hand-written list once).
#include "reports/detection_debug.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "tests/test_util.h"

namespace furn {
namespace {

// A learned run over a grid per class, of a model with one CAD model of
// each class.
DetectionResult LearnedRunOfEveryClass(TrainedModel* model) {
  DetectionResult result;
  result.world_from_camera.translation() << 0, -2, 1;
  for (int k = 0; k < 50; ++k) result.debug.points.emplace_back(0.02f * k, 1.0f, 0.5f);
  result.debug.segment_of_point.assign(result.debug.points.size(), -1);
  for (FurnitureClass c : kAllClasses) {
    DetectionDebug::VoteGrid grid;
    grid.furniture_class = c;
    grid.cell_m = 0.1;
    grid.cols = grid.rows = 8;
    grid.values.assign(64, 0.25f);
    grid.learned = true;
    result.debug.grids.push_back(grid);
    model->model_names.push_back(std::string("model of ") + ClassName(c));
    model->model_classes.push_back(c);
    ModelShape shape;
    shape.points = {Eigen::Vector3f::Zero()};
    shape.normals = {Eigen::Vector3f::UnitZ()};
    shape.high << 0.5f, 0.5f, 0.8f;
    model->model_shapes.push_back(shape);
  }
  return result;
}

TEST(DetectionDebug, ListsEveryImageItWroteSofaIncluded) {
  const std::string dir = testing::ScratchDir();
  TrainedModel model;
  const DetectionResult result = LearnedRunOfEveryClass(&model);
  const std::vector<std::string> images =
      WriteDetectionDebug(result, model, CameraIntrinsics::KinectV1(), {}, dir);
  const std::vector<std::string> expected = {"fitted.png",
                                             "topdown.png",
                                             "heat.png",
                                             "votes_chair.png",
                                             "votes_armchair.png",
                                             "votes_table.png",
                                             "votes_sideboard.png",
                                             "votes_sofa.png"};
  EXPECT_EQ(images, expected);
  for (const std::string& image : images)
    EXPECT_TRUE(std::filesystem::is_regular_file(dir + "/" + image)) << image;
  EXPECT_FALSE(std::filesystem::exists(dir + "/segments.png"));
}

TEST(DetectionDebug, ListsNoVoteMapOfAClassTheModelLacks) {
  const std::string dir = testing::ScratchDir();
  TrainedModel model;
  DetectionResult result = LearnedRunOfEveryClass(&model);
  model.model_classes.back() = FurnitureClass::kChair;  // no sofa model
  const std::vector<std::string> images =
      WriteDetectionDebug(result, model, CameraIntrinsics::KinectV1(), {}, dir);
  EXPECT_EQ(std::count(images.begin(), images.end(), "votes_sofa.png"), 0);
  EXPECT_FALSE(std::filesystem::exists(dir + "/votes_sofa.png"));
}

}  // namespace
}  // namespace furn
