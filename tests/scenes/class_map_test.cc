#include "scenes/class_map.h"

#include <gtest/gtest.h>

#include "core/util/error.h"
#include "scenes/catalog.h"
#include "scenes/model_folds.h"
#include "scenes/room_composer.h"
#include "tests/scenes/fixtures.h"
#include "tests/test_util.h"

namespace furn {
namespace {

using testing::ErrorOf;

std::string MapJson(const std::string& entries, const std::string& catalogs = R"(["Test.sh3f"])") {
  return R"({"format": "furnidet-class-map", "version": 1, "catalogs": )" + catalogs +
         R"(, "entries": [)" + entries + "]}";
}

TEST(ClassMap, ParsesEntriesAndFlags) {
  const ClassMap map =
      ParseClassMap(MapJson(R"({"id": "Test/marker", "class": "chair", "note": "x"},
                 {"id": "Test/rotated", "class": "table", "evaluation_only": true})"),
                    "map.json");
  ASSERT_EQ(map.entries.size(), 2u);
  EXPECT_EQ(map.catalogs, std::vector<std::string>{"Test.sh3f"});
  EXPECT_EQ(map.entries[0].furniture_class, FurnitureClass::kChair);
  EXPECT_FALSE(map.entries[0].evaluation_only);
  EXPECT_EQ(map.entries[1].furniture_class, FurnitureClass::kTable);
  EXPECT_TRUE(map.entries[1].evaluation_only);
}

TEST(ClassMap, UnknownClassNamesEntryAndClass) {
  const std::string message = ErrorOf(
      [] { ParseClassMap(MapJson(R"({"id": "Test/marker", "class": "stool"})"), "map.json"); });
  EXPECT_EQ(message,
            "map.json: entry 'Test/marker' has unknown class 'stool' (allowed: "
            "chair, armchair, table, "
            "sideboard, sofa)");
}

TEST(ClassMap, StructuralMistakesAreRejected) {
  EXPECT_NE(ErrorOf([] { ParseClassMap("{not json", "m.json"); }).find("m.json: not valid JSON"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] { ParseClassMap(MapJson(""), "m.json"); }).find("names no entries"),
            std::string::npos);
  // A "format" of another type: our line, not nlohmann's type_error (found by tests/fuzz).
  EXPECT_NE(ErrorOf([] {
              ParseClassMap(R"({"format": 1, "version": 1})", "m.json");
            }).find("m.json: \"format\" must be \"furnidet-class-map\""),
            std::string::npos);
  EXPECT_NE(ErrorOf([] {
              ParseClassMap(
                  MapJson(R"({"id": "A/b", "class": "chair"},{"id": "A/b", "class": "table"})",
                          R"(["A.sh3f"])"),
                  "m.json");
            }).find("'A/b' is listed twice"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] {
              ParseClassMap(MapJson(R"({"id": "Other/b", "class": "chair"})"), "m.json");
            }).find("'Other/b' names no listed catalog"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] {
              ParseClassMap(MapJson(R"({"id": "Test/b", "klass": "chair"})"), "m.json");
            }).find("unknown field 'klass'"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] {
              ParseClassMap(R"({"format": "other", "version": 1})", "m.json");
            }).find("\"format\" must be"),
            std::string::npos);
  for (const char* version : {"1.5", "\"1\"", "3", "0"}) {
    EXPECT_NE(ErrorOf([&] {
                ParseClassMap(
                    std::string(R"({"format": "furnidet-class-map", "version": )") + version + "}",
                    "m.json");
              }).find("unsupported class map version"),
              std::string::npos)
        << version;
  }
  EXPECT_NE(ErrorOf([] {
              LoadClassMap("/nonexistent/map.json");
            }).find("/nonexistent/map.json: cannot read"),
            std::string::npos);
}

TEST(ClassMap, OpenCatalogClassifiesEntriesFromTheMap) {
  const std::string dir = testing::ScratchDir();
  testing::WriteTestSh3f(dir, "Test.sh3f");
  testing::WriteText(dir + "/map.json", MapJson(R"({"id": "Test/marker", "class": "armchair"})"));
  CatalogOpenOptions options;
  options.catalog_dir = dir;
  const Catalog catalog = OpenCatalog(dir + "/map.json", options);
  EXPECT_EQ(catalog.entries().size(),
            3u);  // the unclassified ones stay as clutter
  ASSERT_EQ(catalog.Classified().size(), 1u);
  EXPECT_EQ(catalog.Classified()[0]->id, "Test/marker");
  EXPECT_EQ(catalog.Classified()[0]->furniture_class, FurnitureClass::kArmchair);
  EXPECT_FALSE(catalog.Get("Test/rotated").furniture_class.has_value());
  EXPECT_TRUE(catalog.Get("Test/rotated").size_m.isApprox(Eigen::Vector3f(0.8f, 1.2f, 2.0f)));
}

// A vote-net-only entry: in the catalog with its class, but out of the
// codebook's and evaluation's rooms and out of protocol E's folds, so that
// adding one changes no dataset and no fold.
TEST(ClassMap, VoteNetOnlyEntriesStayOutOfEvaluationRoomsAndFolds) {
  const std::string dir = testing::ScratchDir();
  testing::WriteTestSh3f(dir, "Test.sh3f");
  CatalogOpenOptions options;
  options.catalog_dir = dir;
  testing::WriteText(dir + "/both.json", MapJson(R"({"id": "Test/marker", "class": "chair"},
                                {"id": "Test/rotated", "class": "chair"})"));
  testing::WriteText(dir + "/extra.json", MapJson(R"({"id": "Test/marker", "class": "chair"},
                                {"id": "Test/rotated", "class": "chair", "vote_net_only": true})"));
  const Catalog both = OpenCatalog(dir + "/both.json", options);
  const Catalog extra = OpenCatalog(dir + "/extra.json", options);
  EXPECT_FALSE(extra.Get("Test/marker").vote_net_only);
  EXPECT_TRUE(extra.Get("Test/rotated").vote_net_only);
  EXPECT_EQ(extra.Get("Test/rotated").furniture_class, FurnitureClass::kChair);

  // Rooms: evaluation's leave it out (and do not take it for clutter); the
  // vote network's training rooms place it.
  const ComposerCatalog evaluation = ComposerCatalog::From(extra);
  ASSERT_EQ(evaluation.furniture.size(), 1u);
  EXPECT_EQ(evaluation.furniture[0].id, "Test/marker");
  for (const ComposerCatalog::Item& item : evaluation.clutter) EXPECT_NE(item.id, "Test/rotated");
  RoomOptions training_rooms;
  training_rooms.include_evaluation_only = false;
  training_rooms.include_vote_net_only = true;
  EXPECT_EQ(ComposerCatalog::From(extra, training_rooms).furniture.size(), 2u);
  EXPECT_EQ(ComposerCatalog::From(both).furniture.size(), 2u);

  // Folds: two chairs make two folds; with one of them vote-net-only there is
  // one chair to split.
  EXPECT_EQ(AssignModelFolds(both, 2, 1).fold_of_model.size(), 2u);
  EXPECT_NE(ErrorOf([&] {
              AssignModelFolds(extra, 2, 1);
            }).find("has 1 chair models, fewer than the 2 leave-models-out folds"),
            std::string::npos);
}

TEST(ClassMap, VoteNetOnlyMistakesAreRejected) {
  EXPECT_NE(ErrorOf([] {
              ParseClassMap(MapJson(R"({"id": "Test/b", "class": "chair", "vote_net_only": 1})"),
                            "m.json");
            }).find("m.json: entries[0] \"vote_net_only\" must be true or false"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] {
              ParseClassMap(MapJson(R"({"id": "Test/b", "class": "chair", "vote_net_only": true,
                                        "evaluation_only": true})"),
                            "m.json");
            }).find("is \"evaluation_only\" and \"vote_net_only\": one excludes the other"),
            std::string::npos);
}

TEST(ClassMap, EntryMissingFromTheCatalogIsRejected) {
  const std::string dir = testing::ScratchDir();
  testing::WriteTestSh3f(dir, "Test.sh3f");
  testing::WriteText(dir + "/map.json", MapJson(R"({"id": "Test/sofa9", "class": "sofa"})"));
  CatalogOpenOptions options;
  options.catalog_dir = dir;
  const std::string message = ErrorOf([&] { OpenCatalog(dir + "/map.json", options); });
  EXPECT_EQ(message,
            dir +
                "/map.json: entry 'Test/sofa9' does not exist in catalog "
                "Test.sh3f (in " +
                dir + ")");
}

TEST(ClassMap, UnknownEntryLookupSuggestsCloseIds) {
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog(testing::WriteTestSh3f(dir, "Test.sh3f"));
  const std::string message = ErrorOf([&] { catalog.Get("Test/markr"); });
  EXPECT_NE(message.find("entry 'Test/markr' is not in catalog"), std::string::npos);
  EXPECT_NE(message.find("closest: Test/marker"), std::string::npos) << message;
}

TEST(ClassMap, DefaultFallsBackToProceduralWithoutThePackage) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/class_map.json",
                     MapJson(R"({"id": "Test/marker", "class": "chair"})"));
  CatalogOpenOptions options;
  options.data_dir = dir;
  options.catalog_dir = dir + "/no-such-dir";
  const Catalog catalog = OpenCatalog("default", options);
  EXPECT_EQ(catalog.description(), "default (procedural fallback)");
  ASSERT_EQ(catalog.warnings().size(), 1u);
  EXPECT_NE(catalog.warnings()[0].find("sweethome3d-furniture"), std::string::npos);
  EXPECT_EQ(catalog.Classified().size(), 16u);
  options.allow_procedural_fallback = false;
  EXPECT_NE(ErrorOf([&] { OpenCatalog("default", options); }).find("file does not exist"),
            std::string::npos);
}

TEST(ClassMap, UnknownCatalogSpecIsRejected) {
  EXPECT_NE(ErrorOf([] { OpenCatalog("bogus"); }).find("unknown catalog 'bogus'"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] { OpenCatalog("procedural:x1"); }).find("must be a whole number"),
            std::string::npos);
}

}  // namespace
}  // namespace furn
