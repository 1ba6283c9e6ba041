#include "scenes/model_folds.h"

#include <algorithm>

#include "core/util/error.h"
#include "core/util/random.h"

namespace furn {

std::set<std::string> ModelFolds::ModelsOf(int fold) const {
  std::set<std::string> ids;
  for (const auto& [id, f] : fold_of_model) {
    if (f == fold) ids.insert(id);
  }
  return ids;
}

ModelFolds AssignModelFolds(const Catalog& catalog, int folds, uint64_t seed) {
  Require(folds >= 2 && folds <= 20,
          "leave-models-out folds " + std::to_string(folds) + " must be in 2..20");
  std::map<FurnitureClass, std::vector<std::string>> ids_of_class;
  for (const CatalogEntry* entry : catalog.Classified())
    if (!entry->vote_net_only) ids_of_class[*entry->furniture_class].push_back(entry->id);
  Require(!ids_of_class.empty(),
          "catalog " + catalog.description() + " has no class-mapped entries to split into folds");
  ModelFolds result;
  result.count = folds;
  Rng rng(DeriveSeed(seed, 0xF01D));
  int next_fold = 0;
  for (auto& [furniture_class, ids] : ids_of_class) {
    Require(static_cast<int>(ids.size()) >= folds,
            "catalog " + catalog.description() + " has " + std::to_string(ids.size()) + " " +
                ClassName(furniture_class) + " models, fewer than the " + std::to_string(folds) +
                " leave-models-out folds");
    std::sort(ids.begin(), ids.end());       // the catalog's order must not matter
    for (size_t i = ids.size(); i > 1; --i)  // Fisher-Yates with our generator
      std::swap(ids[i - 1], ids[rng.UniformInt(0, static_cast<int64_t>(i) - 1)]);
    for (const std::string& id : ids) {
      result.fold_of_model[id] = next_fold;
      next_fold = (next_fold + 1) % folds;
    }
  }
  return result;
}

}  // namespace furn
