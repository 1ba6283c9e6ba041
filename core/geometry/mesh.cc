#include "core/geometry/mesh.h"

#include <xxhash.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "core/util/error.h"

namespace furn {

Box3 BoundingBox(const TriangleMesh& mesh) {
  Require(!mesh.Empty(), "bounding box of a mesh without triangles");
  Box3 box;
  box.min.setConstant(std::numeric_limits<float>::infinity());
  box.max.setConstant(-std::numeric_limits<float>::infinity());
  for (const Eigen::Vector3i& triangle : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f& p = mesh.vertices[triangle[k]];
      box.min = box.min.cwiseMin(p);
      box.max = box.max.cwiseMax(p);
    }
  }
  return box;
}

void TransformMesh(const Eigen::Matrix3f& linear,
                   const Eigen::Vector3f& translation,
                   TriangleMesh* mesh) {
  for (Eigen::Vector3f& p : mesh->vertices) p = linear * p + translation;
  if (linear.determinant() < 0) {
    for (Eigen::Vector3i& triangle : mesh->triangles) {
      std::swap(triangle[1], triangle[2]);
    }
  }
}

void AppendMesh(const TriangleMesh& part, TriangleMesh* mesh) {
  const int offset = static_cast<int>(mesh->vertices.size());
  mesh->vertices.insert(mesh->vertices.end(), part.vertices.begin(), part.vertices.end());
  for (const Eigen::Vector3i& triangle : part.triangles) {
    mesh->triangles.push_back(triangle.array() + offset);
  }
}

void PlaceOnFloorCentred(TriangleMesh* mesh) {
  const Box3 box = BoundingBox(*mesh);
  const Eigen::Vector3f shift(-box.Center().x(), -box.Center().y(), -box.min.z());
  TransformMesh(Eigen::Matrix3f::Identity(), shift, mesh);
}

TriangleMesh SimplifyMesh(const TriangleMesh& mesh, float cell_m) {
  Require(cell_m > 0 && std::isfinite(cell_m), "mesh simplification cell must be > 0");
  auto cell_of = [cell_m](const Eigen::Vector3f& p) {
    return std::array<int64_t, 3>{static_cast<int64_t>(std::floor(p.x() / cell_m)),
                                  static_cast<int64_t>(std::floor(p.y() / cell_m)),
                                  static_cast<int64_t>(std::floor(p.z() / cell_m))};
  };
  std::map<std::array<int64_t, 3>, int> cells;
  std::vector<int> remap(mesh.vertices.size());
  std::vector<Eigen::Vector3d> sums;
  std::vector<int> counts;
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const auto [it, added] =
        cells.emplace(cell_of(mesh.vertices[i]), static_cast<int>(sums.size()));
    if (added) {
      sums.push_back(Eigen::Vector3d::Zero());
      counts.push_back(0);
    }
    remap[i] = it->second;
    sums[it->second] += mesh.vertices[i].cast<double>();
    ++counts[it->second];
  }
  TriangleMesh simple;
  simple.vertices.reserve(sums.size());
  for (size_t c = 0; c < sums.size(); ++c)
    simple.vertices.push_back((sums[c] / counts[c]).cast<float>());
  std::set<std::array<int, 3>> seen;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3i r(remap[t.x()], remap[t.y()], remap[t.z()]);
    if (r.x() == r.y() || r.y() == r.z() || r.x() == r.z()) continue;
    // One key per triangle whatever its winding's starting corner.
    std::array<int, 3> key{r.x(), r.y(), r.z()};
    std::rotate(key.begin(), std::min_element(key.begin(), key.end()), key.end());
    if (!seen.insert(key).second) continue;
    simple.triangles.push_back(r);
  }
  // Drop the vertices no triangle uses any more.
  std::vector<int> used(simple.vertices.size(), -1);
  TriangleMesh compact;
  for (Eigen::Vector3i& t : simple.triangles) {
    for (int k = 0; k < 3; ++k) {
      int& index = used[t[k]];
      if (index < 0) {
        index = static_cast<int>(compact.vertices.size());
        compact.vertices.push_back(simple.vertices[t[k]]);
      }
      t[k] = index;
    }
  }
  compact.triangles = std::move(simple.triangles);
  return compact;
}

void CheckMeshValid(const TriangleMesh& mesh, const std::string& what) {
  Require(!mesh.Empty(), what + ": mesh has no faces (a model needs at least one triangle)");
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    Require(mesh.vertices[i].allFinite(),
            what + ": vertex " + std::to_string(i) +
                " is not finite (NaN or infinite coordinates are not allowed)");
  }
  const int n = static_cast<int>(mesh.vertices.size());
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Eigen::Vector3i& t = mesh.triangles[i];
    Require(t.minCoeff() >= 0 && t.maxCoeff() < n,
            what + ": triangle " + std::to_string(i) + " indexes a vertex outside 0.." +
                std::to_string(n - 1));
  }
}

ContentHasher::ContentHasher() : state_(XXH3_createState()) {
  XXH3_128bits_reset(static_cast<XXH3_state_t*>(state_));
}

ContentHasher::~ContentHasher() { XXH3_freeState(static_cast<XXH3_state_t*>(state_)); }

void ContentHasher::Update(const void* data, size_t bytes) {
  XXH3_128bits_update(static_cast<XXH3_state_t*>(state_), data, bytes);
}

std::string ContentHasher::HexDigest() const {
  const XXH128_hash_t hash = XXH3_128bits_digest(static_cast<XXH3_state_t*>(state_));
  char text[33];
  std::snprintf(text,
                sizeof(text),
                "%016llx%016llx",
                static_cast<unsigned long long>(hash.high64),
                static_cast<unsigned long long>(hash.low64));
  return text;
}

std::string ShortHash(const std::string& text, size_t digits) {
  Require(digits >= 1 && digits <= 32,
          "a short hash has 1 to 32 hex digits, not " + std::to_string(digits));
  ContentHasher hasher;
  hasher.Update(text.data(), text.size());
  return hasher.HexDigest().substr(0, digits);
}

std::string HashMesh(const TriangleMesh& mesh) {
  ContentHasher hasher;
  hasher.Update(mesh.vertices.data(), mesh.vertices.size() * sizeof(Eigen::Vector3f));
  hasher.Update(mesh.triangles.data(), mesh.triangles.size() * sizeof(Eigen::Vector3i));
  return hasher.HexDigest();
}

double SurfaceArea(const TriangleMesh& mesh) {
  double area = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[t[2]].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

TriangleMesh MakeBox(const Eigen::Vector3f& min_corner, const Eigen::Vector3f& max_corner) {
  TriangleMesh box;
  for (int i = 0; i < 8; ++i) {
    box.vertices.emplace_back((i & 1) ? max_corner.x() : min_corner.x(),
                              (i & 2) ? max_corner.y() : min_corner.y(),
                              (i & 4) ? max_corner.z() : min_corner.z());
  }
  // Two triangles per face, counter-clockwise seen from outside.
  const int faces[6][4] = {{0, 2, 3, 1},   // z min
                           {4, 5, 7, 6},   // z max
                           {0, 1, 5, 4},   // y min
                           {2, 6, 7, 3},   // y max
                           {0, 4, 6, 2},   // x min
                           {1, 3, 7, 5}};  // x max
  for (const auto& f : faces) {
    box.triangles.emplace_back(f[0], f[1], f[2]);
    box.triangles.emplace_back(f[0], f[2], f[3]);
  }
  return box;
}

TriangleMesh MakeCylinder(const Eigen::Vector3f& base_center,
                          float radius,
                          float height,
                          int segments) {
  Require(segments >= 3, "cylinder segments " + std::to_string(segments) + " must be >= 3");
  TriangleMesh cylinder;
  const Eigen::Vector3f top_center = base_center + Eigen::Vector3f(0, 0, height);
  cylinder.vertices.push_back(base_center);  // 0
  cylinder.vertices.push_back(top_center);   // 1
  for (int i = 0; i < segments; ++i) {
    const double angle = 2.0 * M_PI * i / segments;
    const Eigen::Vector3f offset(radius * std::cos(angle), radius * std::sin(angle), 0);
    cylinder.vertices.push_back(base_center + offset);  // 2 + 2i
    cylinder.vertices.push_back(top_center + offset);   // 3 + 2i
  }
  for (int i = 0; i < segments; ++i) {
    const int b0 = 2 + 2 * i, t0 = b0 + 1;
    const int b1 = 2 + 2 * ((i + 1) % segments), t1 = b1 + 1;
    cylinder.triangles.emplace_back(0, b1, b0);  // bottom cap, facing -z
    cylinder.triangles.emplace_back(1, t0, t1);  // top cap, facing +z
    cylinder.triangles.emplace_back(b0, b1, t1);
    cylinder.triangles.emplace_back(b0, t1, t0);
  }
  return cylinder;
}

}  // namespace furn
