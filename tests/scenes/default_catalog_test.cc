// The default class map against Debian's sweethome3d-furniture package: every
// classified entry loads, with its bounding box within 1 % of the catalog's
// width x depth x height and its base at z = 0.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>

#include "scenes/catalog.h"
#include "scenes/model_folds.h"
#include "scenes/room_composer.h"
#include "tests/scenes/vote_net_only_map.h"
#include "tests/test_util.h"

namespace furn {
namespace {

constexpr char kPackageDir[] = "/usr/share/sweethome3d/furniture";

class DefaultCatalog : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(std::string(kPackageDir) + "/Scopia.sh3f")) {
      GTEST_SKIP() << "sweethome3d-furniture is not installed";
    }
    CatalogOpenOptions options;
    options.allow_procedural_fallback = false;
    catalog_ = std::make_unique<Catalog>(OpenCatalog("default", options));
  }
  std::unique_ptr<Catalog> catalog_;
};

TEST_F(DefaultCatalog, CoversTheRequiredClassesFromTheThreeCatalogs) {
  std::map<FurnitureClass, int> per_class;
  std::map<std::string, int> per_catalog;
  for (const CatalogEntry* entry : catalog_->Classified()) {
    ++per_class[*entry->furniture_class];
    ++per_catalog[entry->id.substr(0, entry->id.find('/'))];
  }
  EXPECT_GE(per_class[FurnitureClass::kChair], 8);
  EXPECT_GE(per_class[FurnitureClass::kArmchair], 5);
  EXPECT_GE(per_class[FurnitureClass::kTable], 8);
  EXPECT_GE(per_class[FurnitureClass::kSideboard], 4);
  EXPECT_GE(catalog_->Classified().size(), 25u);
  EXPECT_EQ(per_catalog.size(), 3u);
  EXPECT_GT(per_catalog["Scopia"], 0);
  EXPECT_GT(per_catalog["BlendSwap-CC-0"], 0);
  EXPECT_GT(per_catalog["BlendSwap-CC-BY"], 0);
  // Unclassified entries stay available as clutter.
  EXPECT_GT(catalog_->entries().size(), 600u);
}

TEST_F(DefaultCatalog, EveryClassifiedModelLoadsAtCatalogSizeOnTheFloor) {
  std::vector<std::string> ids;
  for (const CatalogEntry* entry : catalog_->Classified()) ids.push_back(entry->id);
  const LoadedModels loaded = catalog_->LoadModels(ids);
  for (const ModelLoadFailure& failure : loaded.failures) ADD_FAILURE() << failure.message;
  ASSERT_EQ(loaded.models.size(), ids.size());
  for (const CadModel& model : loaded.models) {
    const Eigen::Vector3f expected = catalog_->Get(model.id).size_m;
    const Box3 box = BoundingBox(model.mesh);
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_NEAR(box.Size()[axis], expected[axis], 0.01 * expected[axis])
          << model.id << " axis " << axis;
    }
    EXPECT_NEAR(box.min.z(), 0, 1e-5) << model.id;
    EXPECT_NEAR(box.Center().head<2>().norm(), 0, 1e-4) << model.id;
    EXPECT_GT(model.mesh.NumTriangles(), 10u) << model.id;
  }
}

// Vote-net-only entries (more tables and sideboards for the vote network's
// rooms) must not move a model of protocol E to another fold: the folds of
// the default map with six of them are the folds without, for three seeds.
TEST_F(DefaultCatalog, VoteNetOnlyEntriesLeaveProtocolEFoldsAsTheyWere) {
  CatalogOpenOptions options;
  options.allow_procedural_fallback = false;
  const Catalog with_extras = OpenCatalog(
      ::furn::testing::WriteDefaultMapWithVoteNetOnlyExtras(::furn::testing::ScratchDir()),
      options);
  int vote_net_only = 0;
  for (const CatalogEntry* entry : with_extras.Classified()) vote_net_only += entry->vote_net_only;
  ASSERT_EQ(vote_net_only, ::furn::testing::kVoteNetOnlyExtras) << "every extra loads";
  for (uint64_t seed : {1, 2, 3}) {
    const ModelFolds with_them = AssignModelFolds(with_extras, 3, seed);
    EXPECT_EQ(with_them.fold_of_model, AssignModelFolds(*catalog_, 3, seed).fold_of_model)
        << "fold seed " << seed;
    EXPECT_EQ(with_them.fold_of_model.size() + vote_net_only, with_extras.Classified().size());
  }
}

// The clutter a room may hold (issue 69): a longer footprint side lets the
// catalogs' beds, long shelves and kitchen runs in beside the furniture.
TEST_F(DefaultCatalog, ALongerClutterSideLetsBedsIn) {
  RoomOptions room;
  const ComposerCatalog usual = ComposerCatalog::From(*catalog_, room);
  room.max_clutter_side_m = 2.4;
  const ComposerCatalog wider = ComposerCatalog::From(*catalog_, room);
  EXPECT_EQ(wider.furniture.size(), usual.furniture.size());
  int long_pieces = 0;
  for (const ComposerCatalog::Item& item : wider.clutter)
    long_pieces += item.size_m.head<2>().maxCoeff() > 1.6;
  EXPECT_EQ(wider.clutter.size(), usual.clutter.size() + long_pieces);
  EXPECT_GE(long_pieces, 5);
}

}  // namespace
}  // namespace furn
