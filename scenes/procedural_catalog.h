// Procedural furniture built from boxes and cylinders, with dimensions drawn
// from a seed: chairs (seat, back, four legs), armchairs (upholstered base,
// arms, back), tables (top on four legs, or a round top on a pedestal),
// sideboards (body on a plinth or legs, top slab) and sofas. Same frame as
// every CadModel: metres, z up, base on z = 0, footprint centred, front
// facing -y. Unit tests use it, and it stands in for the Sweet Home 3D
// catalogs when the package is not installed.
//
//   ProceduralCatalogOptions options;
//   options.seed = 7;
//   for (const ProceduralModel& item : MakeProceduralCatalog(options)) { ... }
#pragma once

#include <cstdint>
#include <vector>

#include "core/geometry/mesh.h"
#include "core/model/furniture_class.h"

namespace furn {

struct ProceduralCatalogOptions {
  uint64_t seed = 1;           // every dimension is drawn from this
  int models_per_class = 4;    // > 0, <= 100
  bool include_sofa = false;   // sofa is an optional class
  int cylinder_segments = 16;  // >= 3

  bool Check() const;
};

struct ProceduralModel {
  CadModel model;  // id "procedural/<class>-<k>"
  FurnitureClass furniture_class = FurnitureClass::kChair;
};

std::vector<ProceduralModel> MakeProceduralCatalog(const ProceduralCatalogOptions& options);

// One model of a class, drawn from `seed`.
ProceduralModel MakeProceduralModel(FurnitureClass furniture_class,
                                    uint64_t seed,
                                    int cylinder_segments = 16);

}  // namespace furn
