// Leave-models-out folds: stratified by class, balanced, seeded, and refused
// when a class has fewer models than folds.
#include "scenes/model_folds.h"

#include <gtest/gtest.h>

#include "core/util/error.h"
#include "tests/test_util.h"

namespace furn {
namespace {

TEST(ModelFolds, EveryClassIsSpreadOverEveryFoldAndFoldsAreBalanced) {
  const Catalog catalog = OpenCatalog("procedural:4");  // 4 models per class, 4 classes
  const ModelFolds folds = AssignModelFolds(catalog, 3, 1);
  ASSERT_EQ(folds.count, 3);
  EXPECT_EQ(folds.fold_of_model.size(), catalog.Classified().size());
  std::map<std::pair<int, FurnitureClass>, int> per_fold_class;
  std::map<int, int> per_fold;
  for (const auto& [id, fold] : folds.fold_of_model) {
    ++per_fold_class[{fold, *catalog.Get(id).furniture_class}];
    ++per_fold[fold];
  }
  for (int fold = 0; fold < 3; ++fold) {
    for (FurnitureClass c : {FurnitureClass::kChair,
                             FurnitureClass::kArmchair,
                             FurnitureClass::kTable,
                             FurnitureClass::kSideboard}) {
      const int n = per_fold_class[{fold, c}];
      EXPECT_TRUE(n == 1 || n == 2) << "fold " << fold << " has " << n << " " << ClassName(c);
    }
  }
  // 16 models over 3 folds: 5, 5 and 6.
  EXPECT_LE(std::max({per_fold[0], per_fold[1], per_fold[2]}) -
                std::min({per_fold[0], per_fold[1], per_fold[2]}),
            1);
  // ModelsOf agrees with the map, and the room of fold k is k % K.
  size_t total = 0;
  for (int fold = 0; fold < 3; ++fold) {
    for (const std::string& id : folds.ModelsOf(fold)) EXPECT_EQ(folds.fold_of_model.at(id), fold);
    total += folds.ModelsOf(fold).size();
  }
  EXPECT_EQ(total, folds.fold_of_model.size());
  EXPECT_EQ(folds.FoldOfRoom(7), 1);
}

TEST(ModelFolds, SameSeedSameSplitOtherSeedAnother) {
  const Catalog catalog = OpenCatalog("procedural:4");
  EXPECT_EQ(AssignModelFolds(catalog, 4, 9).fold_of_model,
            AssignModelFolds(catalog, 4, 9).fold_of_model);
  EXPECT_NE(AssignModelFolds(catalog, 4, 9).fold_of_model,
            AssignModelFolds(catalog, 4, 10).fold_of_model);
}

TEST(ModelFolds, TooManyFoldsOrTooFewAreRefusedClearly) {
  const Catalog catalog = OpenCatalog("procedural:4");
  EXPECT_NE(testing::ErrorOf([&] {
              AssignModelFolds(catalog, 5, 1);
            }).find("has 4 chair models, fewer than the 5 leave-models-out folds"),
            std::string::npos)
      << testing::ErrorOf([&] { AssignModelFolds(catalog, 5, 1); });
  EXPECT_NE(testing::ErrorOf([&] { AssignModelFolds(catalog, 1, 1); }).find("must be in 2..20"),
            std::string::npos);
}

}  // namespace
}  // namespace furn
