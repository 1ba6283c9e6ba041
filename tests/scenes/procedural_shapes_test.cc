// Shape variety for the vote network's training rooms: varied tables and
// sideboards come in several styles, sized within the range given, the same
// seed gives the same mesh; a catalog copy takes them as classified entries
// without changing the catalog it was copied from.
#include "scenes/procedural_shapes.h"

#include <gtest/gtest.h>

#include <set>

#include "core/error.h"

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
