// Shape variety for the classes with few CAD models (issue 37): procedural
// tables and sideboards in the styles furniture catalogs hold — tables on
// four legs (with or without an apron), on a pedestal (round or square top),
// on trestles; sideboards on legs or a plinth, with doors, drawers or open
// shelves — their proportions drawn within the sizes a catalog has of the
// class. The vote network's training rooms mix them in (never evaluation
// rooms): the network is to learn what a table is, not the few tables of one
// catalog.
//
//   const SizeRange range = ClassSizeRange(catalog, FurnitureClass::kTable, held_out);
//   const ProceduralModel table = MakeVariedModel(FurnitureClass::kTable, range, seed);
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "scenes/catalog.h"
#include "scenes/procedural_catalog.h"

namespace furn {

// Footprint width (x), depth (y) and height (z) bounds, metres.
struct SizeRange {
  Eigen::Vector3f min_m = Eigen::Vector3f::Zero();
  Eigen::Vector3f max_m = Eigen::Vector3f::Zero();
};

// The sizes of the catalog's trainable entries of a class (not evaluation
// only, not in `excluded`); throws InputError when it has none.
SizeRange ClassSizeRange(const Catalog& catalog,
                         FurnitureClass furniture_class,
                         const std::set<std::string>& excluded);

// The classes shape variety is made for.
bool HasShapeVariety(FurnitureClass furniture_class);

// One table or sideboard of a style drawn from `seed`, sized within `range`
// (metres; z up, base on z = 0, footprint centred, front facing -y). Throws
// InputError for a class without shape variety.
ProceduralModel MakeVariedModel(FurnitureClass furniture_class,
                                const SizeRange& range,
                                uint64_t seed);

// `per_class` varied models of each class with shape variety that the catalog
// trains on, ids "varied/<class>-<k>", sized by ClassSizeRange.
std::vector<ProceduralModel> MakeShapeVariety(const Catalog& catalog,
                                              const std::set<std::string>& excluded,
                                              int per_class,
                                              uint64_t seed);

}  // namespace furn
