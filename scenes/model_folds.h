// Leave-models-out folds (SPEC §9 protocol E): the class-mapped CAD models of
// a catalog split into K folds, stratified by class and seeded. Fold k's
// models are held out of training and are the only targets of the rooms that
// evaluate it, so the detector is measured on furniture it has never seen.
// Generation (room k belongs to fold k % K) and cross-validation both call
// AssignModelFolds, so they agree on the split.
//
//   const ModelFolds folds = AssignModelFolds(catalog, 5, /*seed=*/1);
//   for (const std::string& id : folds.ModelsOf(2)) ...   // fold 2's models
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>

#include "scenes/catalog.h"

namespace furn {

// The fold whose models are the targets of room `room_index` of a dataset
// generated with `folds` model folds: the one rule generation and evaluation share.
inline int FoldOfRoom(int64_t room_index, int folds) {
  return static_cast<int>(room_index % folds);
}

struct ModelFolds {
  int count = 0;
  std::map<std::string, int> fold_of_model;  // every class-mapped entry

  std::set<std::string> ModelsOf(int fold) const;
  // The fold whose models are the targets of room `room_index`.
  int FoldOfRoom(int64_t room_index) const { return furn::FoldOfRoom(room_index, count); }
};

// Per class, the entries (evaluation-only ones included: under this protocol
// every model is held out once) in a seeded shuffle are dealt to the folds in
// turn, each class continuing where the last one stopped, so fold sizes differ
// by at most one. Throws InputError unless 2 <= folds <= 20 and every class
// present has at least `folds` models (else some fold would lack the class).
ModelFolds AssignModelFolds(const Catalog& catalog, int folds, uint64_t seed);

}  // namespace furn
