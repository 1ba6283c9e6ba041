#include "scenes/procedural_catalog.h"

#include <gtest/gtest.h>

#include <set>

#include "core/util/error.h"

namespace furn {
namespace {

TEST(Procedural, SameSeedSameModelsDifferentSeedDifferent) {
  ProceduralCatalogOptions options;
  options.seed = 11;
  const auto a = MakeProceduralCatalog(options);
  const auto b = MakeProceduralCatalog(options);
  options.seed = 12;
  const auto c = MakeProceduralCatalog(options);
  ASSERT_EQ(a.size(), 16u);
  int same_as_other_seed = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].model.content_hash, b[i].model.content_hash);
    same_as_other_seed += a[i].model.content_hash == c[i].model.content_hash;
  }
  EXPECT_EQ(same_as_other_seed, 0);
}

TEST(Procedural, EveryModelIsNormalisedAndDistinct) {
  ProceduralCatalogOptions options;
  options.include_sofa = true;
  const auto catalog = MakeProceduralCatalog(options);
  ASSERT_EQ(catalog.size(), 20u);
  std::set<std::string> hashes, ids;
  for (const ProceduralModel& item : catalog) {
    const Box3 box = BoundingBox(item.model.mesh);
    EXPECT_NEAR(box.min.z(), 0, 1e-6) << item.model.id;
    EXPECT_NEAR(box.Center().x(), 0, 1e-5) << item.model.id;
    EXPECT_NEAR(box.Center().y(), 0, 1e-5) << item.model.id;
    hashes.insert(item.model.content_hash);
    ids.insert(item.model.id);
  }
  EXPECT_EQ(hashes.size(), catalog.size());
  EXPECT_EQ(ids.size(), catalog.size());
}

// Plausible real-world sizes per class (metres): [min, max] of width, depth,
// height.
struct SizeRange {
  FurnitureClass furniture_class;
  Eigen::Vector3f low, high;
};

TEST(Procedural, DimensionsArePlausibleForEachClass) {
  const SizeRange ranges[] = {
      {FurnitureClass::kChair, {0.40f, 0.40f, 0.77f}, {0.50f, 0.50f, 0.98f}},
      {FurnitureClass::kArmchair, {0.65f, 0.65f, 0.73f}, {0.90f, 0.85f, 0.95f}},
      {FurnitureClass::kTable, {0.80f, 0.60f, 0.70f}, {1.80f, 1.20f, 0.78f}},
      {FurnitureClass::kSideboard, {1.00f, 0.40f, 0.70f}, {2.06f, 0.58f, 0.95f}},
  };
  for (const SizeRange& range : ranges) {
    for (uint64_t seed = 1; seed <= 30; ++seed) {
      const Eigen::Vector3f size =
          BoundingBox(MakeProceduralModel(range.furniture_class, seed).model.mesh).Size();
      for (int axis = 0; axis < 3; ++axis) {
        EXPECT_GE(size[axis], range.low[axis] - 1e-4f)
            << ClassName(range.furniture_class) << " axis " << axis;
        EXPECT_LE(size[axis], range.high[axis] + 1e-4f)
            << ClassName(range.furniture_class) << " axis " << axis;
      }
    }
  }
}

TEST(Procedural, ChairBackIsAtPlusYSoTheFrontFacesMinusY) {
  for (uint64_t seed = 1; seed <= 10; ++seed) {
    const TriangleMesh mesh = MakeProceduralModel(FurnitureClass::kChair, seed).model.mesh;
    const float top = BoundingBox(mesh).max.z();
    for (const Eigen::Vector3f& p : mesh.vertices) {
      if (p.z() > top - 0.05f) {
        EXPECT_GT(p.y(), 0) << "seed " << seed;
      }
    }
  }
}

TEST(Procedural, BadOptionsAreRejected) {
  ProceduralCatalogOptions options;
  options.models_per_class = 0;
  EXPECT_THROW(MakeProceduralCatalog(options), InputError);
}

}  // namespace
}  // namespace furn
