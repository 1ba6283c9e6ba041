#include "reports/mesh_sheet.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/util/error.h"
#include "scenes/procedural_catalog.h"
#include "tests/test_util.h"

namespace furn {
namespace {

TEST(MeshSheet, DrawsEveryModelInItsTile) {
  const auto catalog = MakeProceduralCatalog(ProceduralCatalogOptions{});
  std::vector<SheetTile> tiles;
  for (const ProceduralModel& item : catalog)
    tiles.push_back({&item.model.mesh, item.model.id, "sub"});
  MeshSheetOptions options;
  options.tile_px = 100;
  options.columns = 4;
  const std::string path = testing::ScratchDir() + "/sheet.png";
  WriteMeshSheet(tiles, options, path);
  const cv::Mat sheet = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(sheet.empty());
  EXPECT_EQ(sheet.cols, 400);
  EXPECT_EQ(sheet.rows, 4 * (100 + 38));
  for (size_t i = 0; i < tiles.size(); ++i) {
    const cv::Rect picture((i % 4) * 100, (i / 4) * 138, 100, 100);
    cv::Mat gray;
    cv::cvtColor(sheet(picture), gray, cv::COLOR_BGR2GRAY);
    // The model covers a good part of its tile (background is 250).
    EXPECT_GT(cv::countNonZero(gray < 240), 800) << tiles[i].title;
  }
}

TEST(MeshSheet, BadRequestsLeaveNoFile) {
  const std::string dir = testing::ScratchDir();
  EXPECT_THROW(WriteMeshSheet({}, MeshSheetOptions{}, dir + "/empty.png"), InputError);
  const TriangleMesh box = MakeBox({0, 0, 0}, {1, 1, 1});
  MeshSheetOptions bad;
  bad.tile_px = 4;
  EXPECT_THROW(WriteMeshSheet({{&box, "a", "b"}}, bad, dir + "/bad.png"), InputError);
  EXPECT_THROW(WriteMeshSheet({{&box, "a", "b"}}, MeshSheetOptions{}, dir + "/sheet.jpg"),
               InputError);
  EXPECT_THROW(WriteMeshSheet({{&box, "a", "b"}}, MeshSheetOptions{}, dir + "/no/such/dir.png"),
               InputError);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

}  // namespace
}  // namespace furn
