#include "scenes/procedural_shapes.h"

#include <algorithm>

#include "core/util/error.h"
#include "core/util/random.h"

namespace furn {
namespace {

using Eigen::Vector3f;

constexpr int kSegments = 16;

void RequireShapeVariety(FurnitureClass furniture_class) {
  Require(HasShapeVariety(furniture_class),
          std::string("no shape variety for class ") + ClassName(furniture_class));
}

void AddBox(TriangleMesh* mesh, Vector3f low, Vector3f high) {
  AppendMesh(MakeBox(low, high), mesh);
}

float Draw(Rng* rng, const SizeRange& range, int axis) {
  return static_cast<float>(
      rng->Uniform(range.min_m[axis], std::max(range.min_m[axis] + 1e-3f, range.max_m[axis])));
}

// Legs (square or round) at the corners of a rectangle of half-size (hx, hy).
void AddCornerLegs(TriangleMesh* mesh, float hx, float hy, float leg, float height, bool round) {
  for (int sx : {-1, 1}) {
    for (int sy : {-1, 1}) {
      const float x = sx * (hx - leg / 2), y = sy * (hy - leg / 2);
      if (round) {
        AppendMesh(MakeCylinder(Vector3f(x, y, 0), leg / 2, height, kSegments), mesh);
      } else {
        AddBox(mesh,
               Vector3f(x - leg / 2, y - leg / 2, 0),
               Vector3f(x + leg / 2, y + leg / 2, height));
      }
    }
  }
}

struct TableSize {
  float hx, hy, height, top;
};

// What decides a varied table besides its size range.
struct TableDraw {
  uint64_t seed;
  ShapeSizes sizes;
  bool cloth;
};

void FourLegTable(Rng* rng, const TableSize& s, TriangleMesh* mesh) {
  const float leg = rng->Uniform(0.035, 0.08), inset = rng->Uniform(0.0, 0.12);
  const float under = s.height - s.top;
  AddCornerLegs(mesh, s.hx - inset, s.hy - inset, leg, under, rng->Bernoulli(0.35));
  if (rng->Bernoulli(0.5)) {  // an apron: a frame under the top
    const float apron = rng->Uniform(0.06, 0.12), t = 0.02f;
    const float ax = s.hx - inset - leg / 2, ay = s.hy - inset - leg / 2;
    for (int side : {-1, 1}) {
      AddBox(mesh,
             Vector3f(-ax, side * ay - t / 2, under - apron),
             Vector3f(ax, side * ay + t / 2, under));
      AddBox(mesh,
             Vector3f(side * ax - t / 2, -ay, under - apron),
             Vector3f(side * ax + t / 2, ay, under));
    }
  }
}

void PedestalTable(Rng* rng, const TableSize& s, TriangleMesh* mesh) {
  const float under = s.height - s.top;
  const float column = rng->Uniform(0.04, 0.09);
  const float foot = std::min(s.hx, s.hy) * rng->Uniform(0.5, 0.8);
  if (rng->Bernoulli(0.5)) {
    AppendMesh(MakeCylinder(Vector3f(0, 0, 0), foot, 0.04f, kSegments), mesh);
  } else {  // a cross foot
    AddBox(mesh, Vector3f(-foot, -0.03f, 0), Vector3f(foot, 0.03f, 0.05f));
    AddBox(mesh, Vector3f(-0.03f, -foot, 0), Vector3f(0.03f, foot, 0.05f));
  }
  AppendMesh(MakeCylinder(Vector3f(0, 0, 0.04f), column, under - 0.04f, kSegments), mesh);
}

void TrestleTable(Rng* rng, const TableSize& s, TriangleMesh* mesh) {
  const float under = s.height - s.top;
  const float inset = rng->Uniform(0.05, 0.2) * s.hx;
  const float post = rng->Uniform(0.05, 0.1), foot_h = 0.05f;
  for (int side : {-1, 1}) {
    const float x = side * (s.hx - inset);
    AddBox(mesh,
           Vector3f(x - post, -s.hy * 0.85f, 0),
           Vector3f(x + post, s.hy * 0.85f, foot_h));  // foot
    AddBox(
        mesh, Vector3f(x - post / 2, -post, foot_h), Vector3f(x + post / 2, post, under));  // post
    AddBox(mesh,
           Vector3f(x - post, -s.hy * 0.8f, under - 0.05f),
           Vector3f(x + post, s.hy * 0.8f, under));
  }
  const float stretcher = rng->Uniform(0.15, 0.4);
  AddBox(mesh,
         Vector3f(-(s.hx - inset), -0.025f, stretcher),
         Vector3f(s.hx - inset, 0.025f, stretcher + 0.06f));
}

// A cloth over a table's top: the top covered and a skirt hanging below it.
// On a round top it falls to the floor more often than not (a cylinder, a
// little flared at its foot: a box, as a sideboard is, but round and of a
// table's height); on a rectangular one it hangs 15-40 cm.
void AddCloth(Rng* rng, const TableSize& s, bool round_top, TriangleMesh* mesh) {
  constexpr float kThickness = 0.01f;
  const bool to_floor = round_top && rng->Bernoulli(0.6);
  const float drop = to_floor
                         ? s.height - 0.01f
                         : std::min(s.height - 0.05f, static_cast<float>(rng->Uniform(0.15, 0.4)));
  const float low = s.height - drop, high = s.height + kThickness;
  if (round_top) {
    const float flare = to_floor ? static_cast<float>(rng->Uniform(0.02, 0.1)) : kThickness;
    AppendMesh(MakeCylinder(Vector3f(0, 0, low), s.hx + flare, high - low, 2 * kSegments), mesh);
    return;
  }
  const float hx = s.hx + kThickness, hy = s.hy + kThickness;
  AddBox(mesh, Vector3f(-hx, -hy, s.height), Vector3f(hx, hy, high));
  for (int side : {-1, 1}) {
    const float y0 = side < 0 ? -hy : s.hy, x0 = side < 0 ? -hx : s.hx;
    AddBox(mesh, Vector3f(-hx, y0, low), Vector3f(hx, y0 + kThickness, high));
    AddBox(mesh, Vector3f(x0, -hy, low), Vector3f(x0 + kThickness, hy, high));
  }
}

TriangleMesh MakeTable(Rng* rng, const SizeRange& range, const TableDraw& draw) {
  float width = Draw(rng, range, 0), depth = Draw(rng, range, 1);
  // The widened range's depths lie within its widths: swapping keeps both in range.
  if (draw.sizes == ShapeSizes::kReal && depth > width) std::swap(width, depth);
  const float height = Draw(rng, range, 2);
  double style = rng->Uniform01();
  // A round top's diameter must fit both the width and the depth ranges.
  const float round_low = std::max(range.min_m.x(), range.min_m.y());
  const float round_high = std::min(range.max_m.x(), range.max_m.y());
  bool round_top = style < 0.25 && rng->Bernoulli(0.6) && round_low <= round_high;
  if (round_top) width = depth = static_cast<float>(rng->Uniform(round_low, round_high + 1e-3));
  // A cloth draws from a stream of its own: the table's other draws stay as
  // they are without it. Half the cloths lie on a round top, on a pedestal
  // (corner legs would stand outside a round top).
  constexpr uint64_t kClothStream = 0xC107;
  Rng cloth_rng(DeriveSeed(draw.seed, kClothStream));
  if (draw.cloth && round_low <= round_high && cloth_rng.Bernoulli(0.5)) {
    round_top = true;
    style = 0;
    width = depth = static_cast<float>(cloth_rng.Uniform(round_low, round_high + 1e-3));
  }
  const TableSize s{width / 2, depth / 2, height, static_cast<float>(rng->Uniform(0.02, 0.06))};
  TriangleMesh mesh;
  if (style < 0.25) {
    PedestalTable(rng, s, &mesh);
  } else if (style < 0.45) {
    TrestleTable(rng, s, &mesh);
  } else {
    FourLegTable(rng, s, &mesh);
  }
  if (round_top) {
    AppendMesh(MakeCylinder(Vector3f(0, 0, s.height - s.top), s.hx, s.top, 2 * kSegments), &mesh);
  } else {
    AddBox(&mesh, Vector3f(-s.hx, -s.hy, s.height - s.top), Vector3f(s.hx, s.hy, s.height));
  }
  if (draw.cloth) AddCloth(&cloth_rng, s, round_top, &mesh);
  return mesh;
}

// The front of a sideboard's body (y = -hy): doors as recessed panels,
// drawers as slabs standing out with handles, or open shelves.
void SideboardFront(Rng* rng, float hx, float hy, float low, float high, TriangleMesh* mesh) {
  const double style = rng->Uniform01();
  const int columns = static_cast<int>(rng->UniformInt(2, 4));
  const float column_w = 2 * hx / columns;
  if (style < 0.4) {  // doors with handles
    for (int c = 0; c < columns; ++c) {
      const float x0 = -hx + c * column_w + 0.01f, x1 = x0 + column_w - 0.02f;
      AddBox(mesh, Vector3f(x0, -hy - 0.015f, low + 0.01f), Vector3f(x1, -hy, high - 0.01f));
      const float hxh = c % 2 == 0 ? x1 - 0.04f : x0 + 0.02f;
      AddBox(mesh,
             Vector3f(hxh, -hy - 0.04f, (low + high) / 2 - 0.06f),
             Vector3f(hxh + 0.02f, -hy - 0.015f, (low + high) / 2 + 0.06f));
    }
  } else if (style < 0.75) {  // rows of drawers
    const int rows = static_cast<int>(rng->UniformInt(2, 4));
    const float row_h = (high - low) / rows;
    for (int c = 0; c < columns; ++c) {
      for (int r = 0; r < rows; ++r) {
        const float x0 = -hx + c * column_w + 0.01f, z0 = low + r * row_h + 0.01f;
        AddBox(mesh,
               Vector3f(x0, -hy - 0.02f, z0),
               Vector3f(x0 + column_w - 0.02f, -hy, z0 + row_h - 0.02f));
        const float xm = x0 + column_w / 2 - 0.05f, zm = z0 + row_h / 2;
        AddBox(mesh,
               Vector3f(xm, -hy - 0.04f, zm - 0.01f),
               Vector3f(xm + 0.1f, -hy - 0.02f, zm + 0.01f));
      }
    }
  }
  // else: open shelves, the body's front left as it is (shelves added by the caller)
}

TriangleMesh MakeSideboard(Rng* rng, const SizeRange& range) {
  const float width = Draw(rng, range, 0), depth = Draw(rng, range, 1),
              height = Draw(rng, range, 2);
  const float hx = width / 2, hy = depth / 2;
  const float top = rng->Uniform(0.02, 0.04);
  const float clearance = rng->Uniform(0.0, std::min(0.3f, height * 0.35f));
  TriangleMesh mesh;
  if (clearance > 0.04f && rng->Bernoulli(0.7)) {
    AddCornerLegs(
        &mesh, hx - 0.02f, hy - 0.02f, rng->Uniform(0.03, 0.05), clearance, rng->Bernoulli(0.5));
  } else if (clearance > 0.02f) {
    AddBox(
        &mesh, Vector3f(-hx + 0.04f, -hy + 0.04f, 0), Vector3f(hx - 0.04f, hy - 0.01f, clearance));
  }
  const bool open = rng->Bernoulli(0.25);
  const float body_top = height - top;
  if (open) {  // sides, back, bottom and shelves: seen into from the front
    const float t = 0.02f;
    AddBox(&mesh, Vector3f(-hx, -hy, clearance), Vector3f(-hx + t, hy, body_top));
    AddBox(&mesh, Vector3f(hx - t, -hy, clearance), Vector3f(hx, hy, body_top));
    AddBox(&mesh, Vector3f(-hx, hy - t, clearance), Vector3f(hx, hy, body_top));
    const int shelves = static_cast<int>(rng->UniformInt(1, 3));
    for (int k = 0; k <= shelves; ++k) {
      const float z = clearance + (body_top - clearance) * k / (shelves + 1);
      AddBox(&mesh, Vector3f(-hx, -hy, z), Vector3f(hx, hy, z + t));
    }
  } else {
    AddBox(&mesh, Vector3f(-hx, -hy + 0.02f, clearance), Vector3f(hx, hy, body_top));
    SideboardFront(rng, hx, hy - 0.02f, clearance, body_top, &mesh);
  }
  const float overhang = rng->Uniform(0.0, 0.03);
  AddBox(&mesh,
         Vector3f(-hx - overhang, -hy - overhang, body_top),
         Vector3f(hx + overhang, hy, height));
  return mesh;
}

}  // namespace

bool HasShapeVariety(FurnitureClass furniture_class) {
  return furniture_class == FurnitureClass::kTable || furniture_class == FurnitureClass::kSideboard;
}

SizeRange TypicalSizeRange(FurnitureClass furniture_class) {
  RequireShapeVariety(furniture_class);
  if (furniture_class == FurnitureClass::kTable)  // cafe tables to eight-seat dining tables
    return SizeRange{Vector3f(0.6f, 0.6f, 0.70f), Vector3f(2.4f, 1.2f, 0.80f)};
  return SizeRange{Vector3f(0.8f, 0.35f, 0.6f), Vector3f(2.2f, 0.6f, 1.0f)};  // sideboards
}

SizeRange Union(const SizeRange& a, const SizeRange& b) {
  return SizeRange{a.min_m.cwiseMin(b.min_m), a.max_m.cwiseMax(b.max_m)};
}

SizeRange ClassSizeRange(const Catalog& catalog,
                         FurnitureClass furniture_class,
                         const std::set<std::string>& excluded) {
  SizeRange range;
  bool any = false;
  for (const CatalogEntry* entry : catalog.Classified()) {
    if (*entry->furniture_class != furniture_class || entry->evaluation_only ||
        excluded.count(entry->id) > 0)
      continue;
    range.min_m = any ? range.min_m.cwiseMin(entry->size_m) : entry->size_m;
    range.max_m = any ? range.max_m.cwiseMax(entry->size_m) : entry->size_m;
    any = true;
  }
  Require(any,
          "catalog '" + catalog.description() + "' has no " + ClassName(furniture_class) +
              " to train on: no size range for its shape variety");
  return range;
}

ProceduralModel MakeVariedModel(FurnitureClass furniture_class,
                                const SizeRange& range,
                                uint64_t seed,
                                ShapeSizes sizes,
                                bool cloth) {
  RequireShapeVariety(furniture_class);
  Require(!cloth || furniture_class == FurnitureClass::kTable, "only a table wears a cloth");
  Require((range.min_m.array() > 0).all() && (range.max_m.array() >= range.min_m.array()).all(),
          "a shape variety size range must be positive and ordered");
  Rng rng(seed);
  ProceduralModel item;
  item.furniture_class = furniture_class;
  TriangleMesh mesh = furniture_class == FurnitureClass::kTable
                          ? MakeTable(&rng, range, TableDraw{seed, sizes, cloth})
                          : MakeSideboard(&rng, range);
  PlaceOnFloorCentred(&mesh);
  item.model.mesh = std::move(mesh);
  item.model.content_hash = HashMesh(item.model.mesh);
  return item;
}

std::vector<ProceduralModel> MakeShapeVariety(const Catalog& catalog,
                                              const std::set<std::string>& excluded,
                                              int per_class,
                                              uint64_t seed,
                                              ShapeSizes sizes) {
  Require(per_class >= 0 && per_class <= 1000,
          "shape variety: " + std::to_string(per_class) + " models per class must be in 0..1000");
  std::vector<ProceduralModel> models;
  for (FurnitureClass furniture_class : kAllClasses) {
    if (!HasShapeVariety(furniture_class) || per_class == 0) continue;
    SizeRange range = ClassSizeRange(catalog, furniture_class, excluded);
    if (sizes == ShapeSizes::kReal) range = Union(range, TypicalSizeRange(furniture_class));
    for (int k = 0; k < per_class; ++k) {
      const uint64_t stream = static_cast<uint64_t>(furniture_class) * 100000 + k;
      const bool cloth = sizes == ShapeSizes::kReal && furniture_class == FurnitureClass::kTable &&
                         k % kClothEvery == kClothEvery / 2;
      ProceduralModel item =
          MakeVariedModel(furniture_class, range, DeriveSeed(seed, stream), sizes, cloth);
      const std::string name = std::string(ClassName(furniture_class)) + "-" + std::to_string(k);
      item.model.id = "varied/" + name;
      item.model.name = "Varied " + name + (cloth ? " (cloth)" : "");
      item.model.source_path = "varied:" + std::to_string(seed);
      models.push_back(std::move(item));
    }
  }
  return models;
}

}  // namespace furn
