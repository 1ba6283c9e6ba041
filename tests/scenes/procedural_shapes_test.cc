// Shape variety for the vote network's training rooms: varied tables and
// sideboards come in several styles, sized within the range given, the same
// seed gives the same mesh; a catalog copy takes them as classified entries
// without changing the catalog it was copied from; real sizes reach the
// class's usual sizes beyond the catalog's, and a share of the tables wear a
// cloth.
#include "scenes/procedural_shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "core/util/error.h"

namespace furn {
namespace {

SizeRange Range(Eigen::Vector3f low, Eigen::Vector3f high) { return SizeRange{low, high}; }

void ExpectWithin(const Eigen::Vector3f& size, const SizeRange& range, float slack) {
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_GE(size[axis], range.min_m[axis] - slack) << "axis " << axis;
    EXPECT_LE(size[axis], range.max_m[axis] + slack) << "axis " << axis;
  }
}

TEST(ProceduralShapes, TablesAndSideboardsVaryInStyleWithinTheRange) {
  const SizeRange tables = Range({0.8f, 0.7f, 0.70f}, {1.8f, 1.0f, 0.78f});
  const SizeRange sideboards = Range({1.0f, 0.4f, 0.7f}, {2.0f, 0.55f, 0.95f});
  for (const auto& [furniture_class, range] : {std::pair{FurnitureClass::kTable, tables},
                                               std::pair{FurnitureClass::kSideboard, sideboards}}) {
    std::set<size_t> triangle_counts;
    for (uint64_t seed = 1; seed <= 40; ++seed) {
      const ProceduralModel item = MakeVariedModel(furniture_class, range, seed);
      EXPECT_EQ(item.furniture_class, furniture_class);
      const Box3 box = BoundingBox(item.model.mesh);
      EXPECT_NEAR(box.min.z(), 0, 1e-5);
      EXPECT_NEAR(box.Center().x(), 0, 0.02);  // footprint centred
      // Overhangs and handles stand out a few centimetres.
      ExpectWithin(box.Size(), range, 0.07f);
      triangle_counts.insert(item.model.mesh.triangles.size());
    }
    EXPECT_GE(triangle_counts.size(), 5u) << ClassName(furniture_class) << ": too few styles";
  }
  EXPECT_EQ(MakeVariedModel(FurnitureClass::kTable, tables, 7).model.content_hash,
            MakeVariedModel(FurnitureClass::kTable, tables, 7).model.content_hash);
  EXPECT_THROW(MakeVariedModel(FurnitureClass::kChair, tables, 1), InputError);
}

TEST(ProceduralShapes, RealSizesReachTheClassesUsualSizes) {
  const Catalog catalog = OpenCatalog("procedural:3");
  const SizeRange own = ClassSizeRange(catalog, FurnitureClass::kTable, {});
  const SizeRange real = Union(own, TypicalSizeRange(FurnitureClass::kTable));
  EXPECT_LE(real.min_m.x(), 0.6f + 1e-6f);
  EXPECT_GE(real.max_m.x(), 2.4f - 1e-6f);
  float narrowest = 1e9f, widest = 0;
  int tables = 0;
  for (const ProceduralModel& item : MakeShapeVariety(catalog, {}, 80, 5, ShapeSizes::kReal)) {
    if (item.furniture_class != FurnitureClass::kTable) {
      ExpectWithin(BoundingBox(item.model.mesh).Size(),
                   Union(ClassSizeRange(catalog, FurnitureClass::kSideboard, {}),
                         TypicalSizeRange(FurnitureClass::kSideboard)),
                   0.07f);
      continue;
    }
    ++tables;
    const Eigen::Vector3f size = BoundingBox(item.model.mesh).Size();
    ExpectWithin(size, real, 0.21f);  // a cloth flares up to 10 cm a side
    EXPECT_LE(size.y(), size.x() + 0.2f) << item.model.id << ": deeper than wide";
    narrowest = std::min(narrowest, size.x());
    widest = std::max(widest, size.x());
  }
  EXPECT_EQ(tables, 80);
  EXPECT_LT(narrowest, std::max(0.75f, own.min_m.x() - 0.1f)) << "no small table";
  EXPECT_GT(widest, std::min(2.0f, own.max_m.x() + 0.2f)) << "no large table";
  EXPECT_THROW(TypicalSizeRange(FurnitureClass::kChair), InputError);
}

TEST(ProceduralShapes, ClothedTablesHangToTheFloorOrPartWay) {
  const SizeRange range = Range({0.7f, 0.7f, 0.72f}, {1.8f, 1.0f, 0.76f});
  int to_floor = 0;
  constexpr int kTables = 60;
  for (uint64_t seed = 1; seed <= kTables; ++seed) {
    const TriangleMesh bare = MakeVariedModel(FurnitureClass::kTable, range, seed).model.mesh;
    const ProceduralModel item =
        MakeVariedModel(FurnitureClass::kTable, range, seed, ShapeSizes::kCatalog, true);
    EXPECT_EQ(item.model.content_hash,
              MakeVariedModel(FurnitureClass::kTable, range, seed, ShapeSizes::kCatalog, true)
                  .model.content_hash);
    const Box3 box = BoundingBox(item.model.mesh);
    EXPECT_GT(item.model.mesh.triangles.size(), bare.triangles.size()) << "seed " << seed;
    EXPECT_NEAR(box.max.z(), BoundingBox(bare).max.z() + 0.01f, 1e-4f) << "a cloth on the top";
    ExpectWithin(box.Size(), range, 0.21f);  // a cloth flares up to 10 cm a side
    // To the floor: a round skirt's foot on the outline.
    const float radius = box.Size().x() / 2;
    for (const Eigen::Vector3f& v : item.model.mesh.vertices) {
      const float r = std::hypot(v.x() - box.Center().x(), v.y() - box.Center().y());
      if (v.z() < 0.03f && std::abs(r - radius) < 0.005f) {
        ++to_floor;
        break;
      }
    }
  }
  // Half the cloths lie on round tops, 60 % of those reach the floor.
  EXPECT_GT(to_floor, kTables * 0.1);
  EXPECT_LT(to_floor, kTables * 0.6);
  EXPECT_THROW(MakeVariedModel(FurnitureClass::kSideboard, range, 1, ShapeSizes::kReal, true),
               InputError);
}

TEST(ProceduralShapes, AFifthOfTheRealVarietysTablesWearACloth) {
  const Catalog catalog = OpenCatalog("procedural:3");
  std::vector<std::string> clothed;
  for (const ProceduralModel& item : MakeShapeVariety(catalog, {}, 10, 5, ShapeSizes::kReal)) {
    if (item.model.name.find("cloth") != std::string::npos) clothed.push_back(item.model.id);
  }
  EXPECT_EQ(clothed, (std::vector<std::string>{"varied/table-2", "varied/table-7"}));
  for (const ProceduralModel& item : MakeShapeVariety(catalog, {}, 10, 5)) {
    EXPECT_EQ(item.model.name.find("cloth"), std::string::npos) << "catalog sizes: no cloth";
  }
}

TEST(ProceduralShapes, ACatalogCopyTakesThemAsTrainingEntries) {
  const Catalog catalog = OpenCatalog("procedural:3");
  const size_t entries = catalog.entries().size();
  Catalog training = catalog.Copy();
  training.AddModels(MakeShapeVariety(catalog, {}, 3, 5), "Shape variety", "3 varied per class");
  EXPECT_EQ(catalog.entries().size(), entries) << "the original is unchanged";
  ASSERT_EQ(training.entries().size(), entries + 6);
  const CatalogEntry& table = training.Get("varied/table-0");
  EXPECT_EQ(*table.furniture_class, FurnitureClass::kTable);
  EXPECT_FALSE(table.evaluation_only);
  const CadModel model = training.LoadModel("varied/table-0");
  EXPECT_GT(model.mesh.triangles.size(), 12u);
  EXPECT_TRUE(BoundingBox(model.mesh).Size().isApprox(table.size_m, 1e-5f));
  EXPECT_EQ(training.LoadModel(catalog.entries()[0].id).content_hash,
            catalog.LoadModel(catalog.entries()[0].id).content_hash);
  EXPECT_NE(training.description().find("3 varied per class"), std::string::npos);
  // Twice the same ids: refused, naming the id.
  try {
    training.AddModels(MakeShapeVariety(catalog, {}, 1, 5), "Shape variety", "again");
    FAIL() << "a duplicate id was accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("varied/table-0"), std::string::npos) << error.what();
  }
  // Held out every table: no range to draw from, one line naming the class.
  std::set<std::string> all_tables;
  for (const CatalogEntry* entry : catalog.Classified()) {
    if (*entry->furniture_class == FurnitureClass::kTable) all_tables.insert(entry->id);
  }
  try {
    MakeShapeVariety(catalog, all_tables, 1, 5);
    FAIL() << "no tables to train on, yet a range";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("table"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace furn
