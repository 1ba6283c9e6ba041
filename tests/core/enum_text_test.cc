// One definition of each small enum's names: both directions from one table,
// every value named, and messages that list the allowed names.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "core/detector/detector.h"
#include "core/geometry/voxel_key.h"
#include "core/model/furniture_class.h"
#include "tests/test_util.h"

namespace furn {
namespace {

template <typename E>
void ExpectRoundTrip() {
  std::set<std::string> names;
  for (E value : EnumValues<E>()) {
    const std::string name = EnumName(value);
    EXPECT_TRUE(names.insert(name).second) << "name '" << name << "' twice";
    EXPECT_EQ(ParseEnum<E>(name), value) << name;
  }
  EXPECT_EQ(names.size(), EnumCount<E>());
}

TEST(EnumText, EveryValueHasOneNameAndParsesBack) {
  ExpectRoundTrip<FurnitureClass>();
  ExpectRoundTrip<HypothesisOutcome>();
  ExpectRoundTrip<DetectionStatus>();
  ExpectRoundTrip<DetectionStage>();
}

TEST(EnumText, ClassListsComeFromTheTableAndIncludeSofa) {
  ASSERT_EQ(kAllClasses.size(), 5u);
  EXPECT_EQ(kAllClasses.back(), FurnitureClass::kSofa);
  EXPECT_STREQ(ClassName(FurnitureClass::kSofa), "sofa");
  EXPECT_EQ(EnumNameList<FurnitureClass>(), "chair, armchair, table, sideboard, sofa");
  EXPECT_FALSE(FurnitureClassNamed("stool").has_value());
  EXPECT_EQ(testing::ErrorOf([] { ParseFurnitureClass("stool"); }),
            "unknown class 'stool' (allowed: chair, armchair, table, sideboard, sofa)");
}

TEST(EnumText, StageNamesAreTheTimingKeysRunsStore) {
  // Runs store latency_<stage>_p50_ms and JSON timings by these names: they
  // must not change.
  EXPECT_STREQ(EnumName(DetectionStage::kFitAndVerify), "fit+verify");
  EXPECT_STREQ(EnumName(DetectionStage::kTotal), "total");
  EXPECT_STREQ(EnumName(DetectionStatus::kNoPointsInRange), "no_points_in_range");
  EXPECT_STREQ(OutcomeName(HypothesisOutcome::kLowSeenOccupied), "low_seen_occupied");
  StageTimings timings;
  timings.Add(DetectionStage::kVote, 2.5);
  timings.Add(DetectionStage::kTotal, 9);
  EXPECT_EQ(timings.Of(DetectionStage::kTotal), 9);
  EXPECT_EQ(timings.Of(DetectionStage::kRank), 0);
}

TEST(VoxelKey, NeighbouringCellsDifferAndEqualCellsAgree) {
  const double voxel = 0.05;
  EXPECT_EQ(VoxelKey(Eigen::Vector3f(0.01f, 0.02f, 0.03f), voxel),
            VoxelKey(Eigen::Vector3f(0.04f, 0.0f, 0.049f), voxel));
  std::set<uint64_t> keys;
  for (int x = -1; x <= 1; ++x) {
    for (int y = -1; y <= 1; ++y) {
      for (int z = -1; z <= 1; ++z) keys.insert(VoxelKey(Eigen::Vector3i(x, y, z)));
    }
  }
  EXPECT_EQ(keys.size(), 27u);
  // Negative coordinates floor towards minus infinity: -0.01 is in cell -1.
  EXPECT_EQ(VoxelCell(Eigen::Vector3f(-0.01f, 0.0f, 0.0f), voxel), Eigen::Vector3i(-1, 0, 0));
  // The packing: 21 bits per axis, x highest.
  EXPECT_EQ(VoxelKey(Eigen::Vector3i(0, 0, 0)),
            (uint64_t{1} << 20 << 42) | (uint64_t{1} << 20 << 21) | (uint64_t{1} << 20));
}

}  // namespace
}  // namespace furn
