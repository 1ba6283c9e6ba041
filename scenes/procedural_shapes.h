// Shape variety for the classes with few CAD models (issue 37): procedural
// tables and sideboards in the styles furniture catalogs hold — tables on
// four legs (with or without an apron), on a pedestal (round or square top),
// on trestles; sideboards on legs or a plinth, with doors, drawers or open
// shelves — their proportions drawn within the sizes a catalog has of the
// class. The vote network's training rooms mix them in (never evaluation
// rooms): the network is to learn what a table is, not the few tables of one
// catalog.
//
// With ShapeSizes::kReal the sizes reach beyond the catalog's to the class's
// usual sizes in furniture (a 0.6 m cafe table, a 2.4 m dining table, even
// when the catalog trained on has neither) and a share of the tables wear a
// cloth, to the floor or part way: shapes a catalog of a few dozen tables
// may lack and a room has.
//
//   const SizeRange range = ClassSizeRange(catalog, FurnitureClass::kTable, held_out);
//   const ProceduralModel table = MakeVariedModel(FurnitureClass::kTable, range, seed);
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "core/util/enum_text.h"
#include "scenes/catalog.h"
#include "scenes/procedural_catalog.h"

namespace furn {

// Where the varied models' sizes come from.
enum class ShapeSizes : int {
  kCatalog,  // within the catalog's own entries of the class
  kReal,     // the catalog's range widened to TypicalSizeRange; a fifth of the tables clothed
};

template <>
struct EnumText<ShapeSizes> {
  static constexpr const char* kKind = "shape sizes";
  static constexpr EnumEntry<ShapeSizes> kEntries[] = {{ShapeSizes::kCatalog, "catalog"},
                                                       {ShapeSizes::kReal, "real"}};
};

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

// The usual sizes of a class with shape variety in furniture as sold (not of
// any dataset): tables 0.6-2.4 m wide, 0.6-1.2 m deep, 0.70-0.80 m high;
// sideboards 0.8-2.2 m wide, 0.35-0.6 m deep, 0.6-1.0 m high. Throws
// InputError for a class without shape variety.
SizeRange TypicalSizeRange(FurnitureClass furniture_class);

// The smallest range holding both.
SizeRange Union(const SizeRange& a, const SizeRange& b);

// One table or sideboard of a style drawn from `seed`, sized within `range`
// (metres; z up, base on z = 0, footprint centred, front facing -y). With
// kReal a table is never deeper than wide. A table with `cloth` wears one
// (round tops to the floor more often than not, rectangular ones 15-40 cm;
// drawn from a stream of its own). Throws InputError for a class without
// shape variety, or a cloth on anything but a table.
ProceduralModel MakeVariedModel(FurnitureClass furniture_class,
                                const SizeRange& range,
                                uint64_t seed,
                                ShapeSizes sizes = ShapeSizes::kCatalog,
                                bool cloth = false);

// With kReal, every kClothEvery-th varied table wears a cloth.
inline constexpr int kClothEvery = 5;

// `per_class` varied models of each class with shape variety that the catalog
// trains on, ids "varied/<class>-<k>", sized by ClassSizeRange (with kReal,
// its union with TypicalSizeRange, and the tables k = 2, 7, 12, ... under a
// cloth, named "Varied table-k (cloth)").
std::vector<ProceduralModel> MakeShapeVariety(const Catalog& catalog,
                                              const std::set<std::string>& excluded,
                                              int per_class,
                                              uint64_t seed,
                                              ShapeSizes sizes = ShapeSizes::kCatalog);

}  // namespace furn
