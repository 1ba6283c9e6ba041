#include "scenes/procedural_catalog.h"

#include "core/util/error.h"
#include "core/util/random.h"

namespace furn {
namespace {

using Eigen::Vector3f;

// Appends an axis-aligned box given by centre-free corners.
void AddBox(TriangleMesh* mesh, Vector3f min_corner, Vector3f max_corner) {
  AppendMesh(MakeBox(min_corner, max_corner), mesh);
}

// Four legs under a rectangle of half-size (hx, hy), inset by `inset`.
void AddLegs(TriangleMesh* mesh,
             float hx,
             float hy,
             float inset,
             float leg_size,
             float height,
             bool round,
             int segments) {
  for (int sx : {-1, 1}) {
    for (int sy : {-1, 1}) {
      const float x = sx * (hx - inset - leg_size / 2);
      const float y = sy * (hy - inset - leg_size / 2);
      if (round) {
        AppendMesh(MakeCylinder(Vector3f(x, y, 0), leg_size / 2, height, segments), mesh);
      } else {
        AddBox(mesh,
               Vector3f(x - leg_size / 2, y - leg_size / 2, 0),
               Vector3f(x + leg_size / 2, y + leg_size / 2, height));
      }
    }
  }
}

TriangleMesh MakeChair(Rng* rng, int segments) {
  const float width = rng->Uniform(0.40, 0.50), depth = rng->Uniform(0.40, 0.50);
  const float seat_height = rng->Uniform(0.42, 0.48), seat_thickness = rng->Uniform(0.03, 0.05);
  const float back_height = rng->Uniform(0.35, 0.50), back_thickness = rng->Uniform(0.02, 0.04);
  const float leg = rng->Uniform(0.025, 0.045);
  const bool round_legs = rng->Bernoulli(0.5);
  const float hx = width / 2, hy = depth / 2;
  TriangleMesh mesh;
  AddLegs(&mesh, hx, hy, 0.01f, leg, seat_height - seat_thickness, round_legs, segments);
  AddBox(&mesh, Vector3f(-hx, -hy, seat_height - seat_thickness), Vector3f(hx, hy, seat_height));
  AddBox(&mesh,
         Vector3f(-hx, hy - back_thickness, seat_height),
         Vector3f(hx, hy, seat_height + back_height));
  return mesh;
}

TriangleMesh MakeArmchair(Rng* rng, int /*segments*/) {
  const float width = rng->Uniform(0.65, 0.90), depth = rng->Uniform(0.65, 0.85);
  const float seat_height = rng->Uniform(0.38, 0.45);
  float base_clearance = rng->Uniform(0.0, 0.12);
  const float arm_width = rng->Uniform(0.08, 0.15), arm_height = rng->Uniform(0.18, 0.26);
  const float back_thickness = rng->Uniform(0.12, 0.20), back_height = rng->Uniform(0.35, 0.50);
  const float hx = width / 2, hy = depth / 2;
  TriangleMesh mesh;
  if (base_clearance > 0.03f) {
    AddLegs(&mesh, hx, hy, 0.03f, 0.04f, base_clearance, false, 4);
  } else {
    base_clearance = 0;
  }
  AddBox(&mesh,
         Vector3f(-hx + arm_width, -hy, base_clearance),
         Vector3f(hx - arm_width, hy - back_thickness, seat_height));
  for (int side : {-1, 1}) {
    const float inner = side * (hx - arm_width), outer = side * hx;
    AddBox(&mesh,
           Vector3f(std::min(inner, outer), -hy, base_clearance),
           Vector3f(std::max(inner, outer), hy, seat_height + arm_height));
  }
  AddBox(&mesh,
         Vector3f(-hx + arm_width, hy - back_thickness, base_clearance),
         Vector3f(hx - arm_width, hy, seat_height + back_height));
  return mesh;
}

TriangleMesh MakeTable(Rng* rng, int segments) {
  const float height = rng->Uniform(0.70, 0.78), top_thickness = rng->Uniform(0.03, 0.05);
  TriangleMesh mesh;
  if (rng->Bernoulli(0.3)) {  // round table on a pedestal
    const float radius = rng->Uniform(0.40, 0.60);
    AppendMesh(MakeCylinder(Vector3f(0, 0, 0), rng->Uniform(0.20, 0.30), 0.04f, segments), &mesh);
    AppendMesh(MakeCylinder(Vector3f(0, 0, 0.04f),
                            rng->Uniform(0.04, 0.07),
                            height - top_thickness - 0.04f,
                            segments),
               &mesh);
    AppendMesh(
        MakeCylinder(Vector3f(0, 0, height - top_thickness), radius, top_thickness, 2 * segments),
        &mesh);
    return mesh;
  }
  const float width = rng->Uniform(0.80, 1.80), depth = rng->Uniform(0.60, 1.00);
  const float leg = rng->Uniform(0.04, 0.08), inset = rng->Uniform(0.02, 0.10);
  const float hx = width / 2, hy = depth / 2;
  AddLegs(&mesh, hx, hy, inset, leg, height - top_thickness, rng->Bernoulli(0.3), segments);
  AddBox(&mesh, Vector3f(-hx, -hy, height - top_thickness), Vector3f(hx, hy, height));
  return mesh;
}

TriangleMesh MakeSideboard(Rng* rng, int segments) {
  const float width = rng->Uniform(1.00, 2.00), depth = rng->Uniform(0.40, 0.55);
  const float height = rng->Uniform(0.70, 0.95), top_thickness = rng->Uniform(0.02, 0.04);
  const float clearance = rng->Uniform(0.05, 0.18), overhang = rng->Uniform(0.0, 0.03);
  const float hx = width / 2, hy = depth / 2;
  TriangleMesh mesh;
  if (rng->Bernoulli(0.5)) {
    AddLegs(&mesh, hx, hy, 0.03f, 0.04f, clearance, rng->Bernoulli(0.5), segments);
  } else {
    AddBox(
        &mesh, Vector3f(-hx + 0.03f, -hy + 0.03f, 0), Vector3f(hx - 0.03f, hy - 0.01f, clearance));
  }
  AddBox(&mesh, Vector3f(-hx, -hy, clearance), Vector3f(hx, hy, height - top_thickness));
  AddBox(&mesh,
         Vector3f(-hx - overhang, -hy - overhang, height - top_thickness),
         Vector3f(hx + overhang, hy, height));
  return mesh;
}

TriangleMesh MakeSofa(Rng* rng, int segments) {
  // A sofa is a wide armchair.
  TriangleMesh mesh = MakeArmchair(rng, segments);
  const float stretch = rng->Uniform(2.0, 2.8);
  Eigen::Matrix3f scale = Eigen::Vector3f(stretch, 1, 1).asDiagonal();
  TransformMesh(scale, Vector3f::Zero(), &mesh);
  return mesh;
}

}  // namespace

bool ProceduralCatalogOptions::Check() const {
  return models_per_class > 0 && models_per_class <= 100 && cylinder_segments >= 3;
}

ProceduralModel MakeProceduralModel(FurnitureClass furniture_class,
                                    uint64_t seed,
                                    int cylinder_segments) {
  Rng rng(seed);
  ProceduralModel item;
  item.furniture_class = furniture_class;
  TriangleMesh mesh;
  switch (furniture_class) {
    case FurnitureClass::kChair:
      mesh = MakeChair(&rng, cylinder_segments);
      break;
    case FurnitureClass::kArmchair:
      mesh = MakeArmchair(&rng, cylinder_segments);
      break;
    case FurnitureClass::kTable:
      mesh = MakeTable(&rng, cylinder_segments);
      break;
    case FurnitureClass::kSideboard:
      mesh = MakeSideboard(&rng, cylinder_segments);
      break;
    case FurnitureClass::kSofa:
      mesh = MakeSofa(&rng, cylinder_segments);
      break;
  }
  PlaceOnFloorCentred(&mesh);
  item.model.mesh = std::move(mesh);
  item.model.content_hash = HashMesh(item.model.mesh);
  return item;
}

std::vector<ProceduralModel> MakeProceduralCatalog(const ProceduralCatalogOptions& options) {
  Require(options.Check(),
          "procedural catalog: models_per_class must be in 1..100 and "
          "cylinder_segments >= 3");
  std::vector<ProceduralModel> catalog;
  for (FurnitureClass furniture_class : kAllClasses) {
    if (furniture_class == FurnitureClass::kSofa && !options.include_sofa) continue;
    for (int k = 0; k < options.models_per_class; ++k) {
      const uint64_t stream = static_cast<uint64_t>(furniture_class) * 1000 + k;
      ProceduralModel item = MakeProceduralModel(
          furniture_class, DeriveSeed(options.seed, stream), options.cylinder_segments);
      const std::string name = std::string(ClassName(furniture_class)) + "-" + std::to_string(k);
      item.model.id = "procedural/" + name;
      item.model.name = "Procedural " + name;
      item.model.source_path = "procedural:" + std::to_string(options.seed);
      catalog.push_back(std::move(item));
    }
  }
  return catalog;
}

}  // namespace furn
