#include "renderers/depth_renderer.h"

#include <cmath>

#include "core/util/error.h"
#include "renderers/embree_caster.h"
#include "renderers/osmesa_renderer.h"

namespace furn {
namespace {

constexpr double kMaxCoordinate = 1000.0;  // metres; rooms are far smaller

// Möller–Trumbore: does the ray origin + t * direction, t > 0, cross the
// triangle?
bool RayCrossesTriangle(const Eigen::Vector3d& origin,
                        const Eigen::Vector3d& direction,
                        const Eigen::Vector3d& a,
                        const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c) {
  const Eigen::Vector3d edge1 = b - a, edge2 = c - a;
  const Eigen::Vector3d p = direction.cross(edge2);
  const double determinant = edge1.dot(p);
  if (std::abs(determinant) < 1e-15) return false;
  const Eigen::Vector3d s = origin - a;
  const double u = s.dot(p) / determinant;
  if (u < 0 || u > 1) return false;
  const Eigen::Vector3d q = s.cross(edge1);
  const double v = direction.dot(q) / determinant;
  if (v < 0 || u + v > 1) return false;
  return edge2.dot(q) / determinant > 0;
}

}  // namespace

bool IsInsideMesh(const TriangleMesh& mesh, const Eigen::Vector3d& point) {
  // Directions off the axes, so rays rarely graze the edges of axis-aligned
  // boxes.
  const Eigen::Vector3d directions[3] = {Eigen::Vector3d(0.5773, 0.5774, 0.5775).normalized(),
                                         Eigen::Vector3d(-0.6123, 0.3535, -0.7071).normalized(),
                                         Eigen::Vector3d(0.2673, -0.8018, 0.5345).normalized()};
  int odd = 0;
  for (const Eigen::Vector3d& direction : directions) {
    int crossings = 0;
    for (const Eigen::Vector3i& t : mesh.triangles) {
      crossings += RayCrossesTriangle(point,
                                      direction,
                                      mesh.vertices[t[0]].cast<double>(),
                                      mesh.vertices[t[1]].cast<double>(),
                                      mesh.vertices[t[2]].cast<double>());
    }
    odd += crossings % 2;
  }
  return odd >= 2;
}

const Box3& MeshBoundsCache::BoundsOf(const std::shared_ptr<const TriangleMesh>& mesh) {
  if (entries_.size() > 65536) entries_.clear();
  Entry& entry = entries_[mesh.get()];
  if (entry.mesh.lock() != mesh) entry = Entry{mesh, BoundingBox(*mesh)};
  return entry.bounds;
}

void CheckRenderRequest(const Scene& scene,
                        const CameraIntrinsics& camera,
                        const Eigen::Isometry3d& world_from_camera,
                        MeshBoundsCache* bounds_cache) {
  camera.Check();
  Require(scene.NumTriangles() > 0, "scene is empty (no triangles to render)");
  const Eigen::Vector3d position = world_from_camera.translation();
  Require(world_from_camera.matrix().allFinite() && position.norm() < kMaxCoordinate,
          "camera position must be finite and within 1000 m of the origin");
  Require(std::abs(world_from_camera.linear().determinant() - 1) < 1e-6,
          "world_from_camera rotation must be a proper rotation (det = 1)");
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& object = scene.objects[i];
    const std::string name =
        "scene object " + std::to_string(i) + " (id " + std::to_string(object.instance_id) + ")";
    Require(object.mesh != nullptr, name + " has no mesh");
    Require(object.world_from_object.matrix().allFinite() &&
                object.world_from_object.translation().norm() < kMaxCoordinate,
            name + " pose must be finite and within 1000 m of the origin");
    if (object.mesh->Empty()) continue;
    const Box3 box = bounds_cache ? bounds_cache->BoundsOf(object.mesh) : BoundingBox(*object.mesh);
    Require(box.min.allFinite() && box.max.allFinite() &&
                box.min.cwiseAbs().maxCoeff() < kMaxCoordinate &&
                box.max.cwiseAbs().maxCoeff() < kMaxCoordinate,
            name + " has coordinates beyond 1000 m (is the mesh in metres?)");
    const Eigen::Vector3d local = object.world_from_object.inverse() * position;
    const bool in_box = (local.cast<float>().array() >= box.min.array()).all() &&
                        (local.cast<float>().array() <= box.max.array()).all();
    if (in_box && IsInsideMesh(*object.mesh, local)) {
      throw InputError("camera at (" + std::to_string(position.x()) + ", " +
                       std::to_string(position.y()) + ", " + std::to_string(position.z()) +
                       ") is inside " + name);
    }
  }
}

std::unique_ptr<DepthRenderer> MakeRenderer(RendererKind kind) {
  if (kind == RendererKind::kEmbree) return std::make_unique<EmbreeCaster>();
  return std::make_unique<OsMesaRenderer>();
}

RendererKind ParseRendererKind(const std::string& name) {
  if (name == "osmesa") return RendererKind::kOsMesa;
  if (name == "embree") return RendererKind::kEmbree;
  throw InputError("unknown renderer '" + name + "' (allowed: osmesa, embree)");
}

}  // namespace furn
