#include "renderers/embree_caster.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <unordered_map>

#include "core/geometry/embree_device.h"
#include "core/util/parallel.h"

namespace furn {
namespace {

constexpr int kPacket = 16;

// What identifies a built scene: the meshes, their poses and ids.
struct SceneKey {
  std::vector<const TriangleMesh*> meshes;
  std::vector<Eigen::Matrix<double, 3, 4>> poses;
  std::vector<uint16_t> ids;
  bool operator==(const SceneKey& other) const {
    return meshes == other.meshes && ids == other.ids && poses.size() == other.poses.size() &&
           std::equal(
               poses.begin(), poses.end(), other.poses.begin(), [](const auto& a, const auto& b) {
                 return a == b;
               });
  }
};

SceneKey KeyOf(const Scene& scene) {
  SceneKey key;
  for (const SceneObject& object : scene.objects) {
    key.meshes.push_back(object.mesh.get());
    key.poses.push_back(object.world_from_object.matrix().topRows<3>());
    key.ids.push_back(object.instance_id);
  }
  return key;
}

// Every lane of a packet handed to Embree holds a well-formed ray, active or
// not: some ISA paths (AVX2's 8-wide kernels running a 16-ray packet) read
// and assert on all lanes before applying the valid mask. An inactive lane is
// a zero-length ray from the origin.
template <typename Ray16>
void SetInactiveLane(int k, Ray16* ray) {
  ray->org_x[k] = ray->org_y[k] = ray->org_z[k] = 0.0f;
  ray->dir_x[k] = ray->dir_y[k] = 0.0f;
  ray->dir_z[k] = 1.0f;
  ray->tnear[k] = 0.0f;
  ray->tfar[k] = 0.0f;
  ray->time[k] = 0.0f;
  ray->mask[k] = 0u;
  ray->id[k] = static_cast<unsigned>(k);
  ray->flags[k] = 0;
}

// The primary rays of a camera in packets of 4 x 4 pixels (neighbouring rays
// traverse the same nodes). The ray through (u, v) is (x_u, y_v, 1) in the
// camera frame (z = 1: the hit distance t is the optical-axis depth); in the
// world it is x_u R.col(0) + y_v R.col(1) + R.col(2), of which the column and
// row parts are tabulated.
struct PrimaryRays {
  static constexpr int kTile = 4;
  PrimaryRays(const CameraIntrinsics& camera, const Eigen::Matrix3f& rotation)
      : tiles_x((camera.width + kTile - 1) / kTile),
        tiles_y((camera.height + kTile - 1) / kTile),
        ray_x(tiles_x * kTile),
        ray_y(tiles_y * kTile),
        column_part(ray_x.size()),
        row_part(ray_y.size()) {
    for (size_t u = 0; u < ray_x.size(); ++u) {
      ray_x[u] = camera.RayThroughPixel(u, 0).x();
      column_part[u] = ray_x[u] * rotation.col(0);
    }
    for (size_t v = 0; v < ray_y.size(); ++v) {
      ray_y[v] = camera.RayThroughPixel(0, v).y();
      row_part[v] = ray_y[v] * rotation.col(1) + rotation.col(2);
    }
  }
  // The pixel of lane k of the packet of a tile.
  static int U(int tile_column, int k) { return tile_column * kTile + k % kTile; }
  static int V(int tile_row, int k) { return tile_row * kTile + k / kTile; }

  const int tiles_x, tiles_y;
  std::vector<float> ray_x, ray_y;
  std::vector<Eigen::Vector3f> column_part, row_part;
};

// A packet whose every lane starts at `origin`: Embree writes only tfar and
// the hit, so the rest is set once per packet.
void StartPackets(const Eigen::Vector3f& origin, RTCRayHit16* packet) {
  for (int k = 0; k < kPacket; ++k) {
    packet->ray.org_x[k] = origin.x();
    packet->ray.org_y[k] = origin.y();
    packet->ray.org_z[k] = origin.z();
    packet->ray.tnear[k] = 0.0f;
    packet->ray.time[k] = 0.0f;
    packet->ray.mask[k] = 0xFFFFFFFFu;
    packet->ray.id[k] = static_cast<unsigned>(k);
    packet->ray.flags[k] = 0;
  }
}

// What a packet's hits put into the frame: depth, id and (with
// `camera_from_object_normals`) the normal facing the camera.
struct HitWriter {
  const PrimaryRays& rays;
  const std::vector<uint16_t>& id_of_geometry;
  const std::vector<Eigen::Matrix3f>* camera_from_object_normals;  // null: no normals
  DepthFrame* frame;

  void Write(const RTCRayHit16& packet, int k, int u, int v) const {
    const size_t index = frame->Index(u, v);
    if (packet.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
      frame->depth[index] = 0;
      frame->instance_ids[index] = kNoObjectId;
      if (camera_from_object_normals) frame->normals[index].setZero();
      return;
    }
    // An instance hit is named by instID, a top-level triangle by geomID.
    const unsigned geometry = packet.hit.instID[0][k] != RTC_INVALID_GEOMETRY_ID
                                  ? packet.hit.instID[0][k]
                                  : packet.hit.geomID[k];
    frame->depth[index] = packet.ray.tfar[k];
    frame->instance_ids[index] = id_of_geometry[geometry];
    if (!camera_from_object_normals) return;
    // Embree reports the object-space normal of an instance hit.
    Eigen::Vector3f normal =
        (*camera_from_object_normals)[geometry] *
        Eigen::Vector3f(packet.hit.Ng_x[k], packet.hit.Ng_y[k], packet.hit.Ng_z[k]);
    normal.normalize();
    if (normal.dot(Eigen::Vector3f(rays.ray_x[u], rays.ray_y[v], 1.0f)) > 0) normal = -normal;
    frame->normals[index] = normal;
  }
};

// Lane k of an occlusion packet: a ray from `origin` along `direction`.
void SetOcclusionLane(int k,
                      const Eigen::Vector3f& origin,
                      const Eigen::Vector3f& direction,
                      RTCRay16* packet) {
  packet->org_x[k] = origin.x();
  packet->org_y[k] = origin.y();
  packet->org_z[k] = origin.z();
  packet->dir_x[k] = direction.x();
  packet->dir_y[k] = direction.y();
  packet->dir_z[k] = direction.z();
  packet->tnear[k] = 0.0f;
  packet->tfar[k] = std::numeric_limits<float>::infinity();
  packet->time[k] = 0.0f;
  packet->mask[k] = 0xFFFFFFFFu;
  packet->id[k] = static_cast<unsigned>(k);
  packet->flags[k] = 0;
}

// The coverage of an image region from the coverage of each of its rows.
EmbreeCaster::Coverage MergedRows(const std::vector<EmbreeCaster::Coverage>& rows) {
  EmbreeCaster::Coverage total;
  for (const EmbreeCaster::Coverage& row : rows) {
    if (row.pixels == 0) continue;
    if (total.pixels == 0) {
      total.box = row.box;
    } else {
      total.box = {std::min(total.box[0], row.box[0]),
                   std::min(total.box[1], row.box[1]),
                   std::max(total.box[2], row.box[2]),
                   std::max(total.box[3], row.box[3])};
    }
    total.pixels += row.pixels;
  }
  return total;
}

// Meshes this small go into a scene's top level as world-space triangles.
constexpr size_t kMaxFlatTriangles = 64;

// Object-space acceleration structures of meshes, shared by every caster of
// the process and kept while their mesh lives: a catalog model placed in many
// rooms, or an object cast alone for its amodal mask, is built once. Scenes
// are then two-level: a small top-level structure over instances of these.
class MeshBvhCache {
 public:
  static MeshBvhCache& Instance() {
    static MeshBvhCache* cache = new MeshBvhCache;  // never destroyed: no exit-order issues
    return *cache;
  }

  // The committed scene of `mesh` alone, retained for the caller (who
  // releases it with rtcReleaseScene).
  RTCScene Acquire(const std::shared_ptr<const TriangleMesh>& mesh) {
    std::shared_ptr<Entry> entry;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      std::shared_ptr<Entry>& slot = entries_[mesh.get()];
      // An expired entry at this address belonged to a freed mesh.
      if (slot == nullptr || slot->mesh.expired()) slot = std::make_shared<Entry>(mesh);
      entry = slot;
      if (entries_.size() >= 2 * swept_size_) Sweep();
    }
    std::lock_guard<std::mutex> build_lock(entry->build);
    if (entry->scene == nullptr) entry->scene = Build(*mesh);
    rtcRetainScene(entry->scene);
    return entry->scene;
  }

 private:
  struct Entry {
    explicit Entry(const std::shared_ptr<const TriangleMesh>& of) : mesh(of) {}
    ~Entry() {
      if (scene != nullptr) rtcReleaseScene(scene);
    }
    std::weak_ptr<const TriangleMesh> mesh;
    RTCScene scene = nullptr;
    std::mutex build;
  };

  static RTCScene Build(const TriangleMesh& mesh) {
    RTCDevice device = SharedEmbreeDevice();
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
    AttachTriangles(mesh, Eigen::Isometry3f::Identity(), scene);
    rtcCommitScene(scene);
    return scene;
  }

  // Drops entries whose mesh is gone (casters hold their own references).
  void Sweep() {
    for (auto it = entries_.begin(); it != entries_.end();) {
      it = it->second->mesh.expired() ? entries_.erase(it) : std::next(it);
    }
    swept_size_ = std::max<size_t>(64, entries_.size());
  }

  std::mutex mutex_;
  std::unordered_map<const TriangleMesh*, std::shared_ptr<Entry>> entries_;
  size_t swept_size_ = 64;
};

}  // namespace

struct EmbreeCaster::Impl {
  RTCScene scene = nullptr;
  SceneKey key;
  std::vector<std::shared_ptr<const TriangleMesh>> keep_alive;
  std::vector<RTCScene> mesh_scenes;  // retained from MeshBvhCache
  // Per instance (top-level geometry id): its object's id, and the matrix
  // taking object-space normals to the world (Embree reports the geometric
  // normal of an instance hit in object space).
  std::vector<uint16_t> id_of_geometry;
  std::vector<Eigen::Matrix3f> world_from_object_normals;
  MeshBoundsCache bounds_cache;

  void ReleaseScene() {
    if (scene != nullptr) rtcReleaseScene(scene);
    scene = nullptr;
    for (RTCScene mesh_scene : mesh_scenes) rtcReleaseScene(mesh_scene);
    mesh_scenes.clear();
    keep_alive.clear();
    id_of_geometry.clear();
    world_from_object_normals.clear();
  }
};

EmbreeCaster::EmbreeCaster() : impl_(std::make_unique<Impl>()) {
  RequireEmbreeDevice();  // throws here, not at the first render, when Embree cannot start
}

EmbreeCaster::~EmbreeCaster() { impl_->ReleaseScene(); }

void EmbreeCaster::SetScene(const Scene& scene) {
  SceneKey key = KeyOf(scene);
  if (impl_->scene != nullptr && key == impl_->key) return;
  impl_->ReleaseScene();
  impl_->scene = rtcNewScene(SharedEmbreeDevice());
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_MEDIUM);
  for (const SceneObject& object : scene.objects) {
    if (object.mesh == nullptr || object.mesh->Empty()) continue;
    unsigned geometry_id;
    Eigen::Matrix3f world_from_object_normals = Eigen::Matrix3f::Identity();
    if (object.mesh->NumTriangles() <= kMaxFlatTriangles) {
      // Walls, floor and other boxes: world-space triangles in the top level
      // (rays meeting them skip an instance transform).
      geometry_id =
          AttachTriangles(*object.mesh, object.world_from_object.cast<float>(), impl_->scene);
    } else {
      // An instance of the mesh's cached object-space structure: nothing to build.
      RTCScene mesh_scene = MeshBvhCache::Instance().Acquire(object.mesh);
      impl_->mesh_scenes.push_back(mesh_scene);
      RTCGeometry instance = rtcNewGeometry(SharedEmbreeDevice(), RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(instance, mesh_scene);
      const Eigen::Matrix<float, 3, 4> world_from_object =
          object.world_from_object.matrix().topRows<3>().cast<float>();  // column-major
      rtcSetGeometryTransform(
          instance, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, world_from_object.data());
      rtcCommitGeometry(instance);
      geometry_id = rtcAttachGeometry(impl_->scene, instance);
      rtcReleaseGeometry(instance);
      world_from_object_normals =
          object.world_from_object.linear().inverse().transpose().cast<float>();
    }
    if (impl_->id_of_geometry.size() <= geometry_id) {
      impl_->id_of_geometry.resize(geometry_id + 1, 0);
      impl_->world_from_object_normals.resize(geometry_id + 1, Eigen::Matrix3f::Identity());
    }
    impl_->id_of_geometry[geometry_id] = object.instance_id;
    impl_->world_from_object_normals[geometry_id] = world_from_object_normals;
    impl_->keep_alive.push_back(object.mesh);
  }
  rtcCommitScene(impl_->scene);
  impl_->key = std::move(key);
}

void EmbreeCaster::RenderInto(const Scene& scene,
                              const CameraIntrinsics& camera,
                              const Eigen::Isometry3d& world_from_camera,
                              DepthFrame* out) {
  CheckRenderRequest(scene, camera, world_from_camera, &impl_->bounds_cache);
  SetScene(scene);
  out->Reshape(camera.width, camera.height);  // every pixel is written below
  if (!compute_normals()) out->normals.clear();
  const Eigen::Matrix3f rotation = world_from_camera.linear().cast<float>();
  const Eigen::Vector3f origin = world_from_camera.translation().cast<float>();
  RTCScene rtc_scene = impl_->scene;
  std::vector<Eigen::Matrix3f> camera_from_object_normals;
  if (compute_normals()) {
    for (const Eigen::Matrix3f& world_from_object : impl_->world_from_object_normals)
      camera_from_object_normals.push_back(rotation.transpose() * world_from_object);
  }
  const PrimaryRays rays(camera, rotation);
  const HitWriter writer{
      rays, impl_->id_of_geometry, compute_normals() ? &camera_from_object_normals : nullptr, out};
  ParallelFor(0, rays.tiles_y, [&](int tile_row) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    alignas(64) RTCRayHit16 packet{};  // every lane defined; see SetInactiveLane
    alignas(64) int valid[kPacket] = {};
    StartPackets(origin, &packet);
    for (int tile_column = 0; tile_column < rays.tiles_x; ++tile_column) {
      for (int k = 0; k < kPacket; ++k) {
        const int u = PrimaryRays::U(tile_column, k), v = PrimaryRays::V(tile_row, k);
        valid[k] = u < camera.width && v < camera.height ? -1 : 0;
        const Eigen::Vector3f direction = rays.column_part[u] + rays.row_part[v];
        packet.ray.dir_x[k] = direction.x();
        packet.ray.dir_y[k] = direction.y();
        packet.ray.dir_z[k] = direction.z();
        packet.ray.tfar[k] = std::numeric_limits<float>::infinity();
        packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        packet.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
      }
      rtcIntersect16(valid, rtc_scene, &context, &packet);
      for (int k = 0; k < kPacket; ++k) {
        if (valid[k])
          writer.Write(packet, k, PrimaryRays::U(tile_column, k), PrimaryRays::V(tile_row, k));
      }
    }
  });
}

EmbreeCaster::Coverage EmbreeCaster::CoverageIn(const Scene& scene,
                                                const CameraIntrinsics& camera,
                                                const Eigen::Isometry3d& world_from_camera,
                                                const std::array<int, 4>& region,
                                                KnownHits known_hits) {
  camera.Check();
  SetScene(scene);
  const int u0 = std::max(0, region[0]), v0 = std::max(0, region[1]);
  const int u1 = std::min(camera.width - 1, region[2]), v1 = std::min(camera.height - 1, region[3]);
  if (u1 < u0 || v1 < v0) return Coverage();
  const Eigen::Matrix3f rotation = world_from_camera.linear().cast<float>();
  const Eigen::Vector3f origin = world_from_camera.translation().cast<float>();
  std::vector<Coverage> rows(v1 - v0 + 1);
  RTCScene rtc_scene = impl_->scene;
  ParallelFor(v0, v1 + 1, [&](int v) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    alignas(64) RTCRay16 packet{};  // every lane defined; see SetInactiveLane
    alignas(64) int valid[kPacket] = {};
    Coverage& row = rows[v - v0];
    auto count = [&](int u) {
      if (row.pixels == 0) row.box = {u, v, u, v};
      ++row.pixels;
      row.box[0] = std::min(row.box[0], u);
      row.box[2] = std::max(row.box[2], u);
    };
    // Pixels whose answer the ideal image already gives (the object seen
    // there, or nothing before the far side of its box) are counted without a
    // ray; the rest go to Embree in packets of 16.
    int columns[kPacket];
    int rays = 0;
    auto cast = [&] {
      for (int k = rays; k < kPacket; ++k) {
        valid[k] = 0;
        SetInactiveLane(k, &packet);  // not a ray of an earlier packet either
      }
      rtcOccluded16(valid, rtc_scene, &context, &packet);
      for (int k = 0; k < rays; ++k) {
        if (packet.tfar[k] < 0) count(columns[k]);  // Embree sets tfar to -inf for a hit
      }
      rays = 0;
    };
    for (int u = u0; u <= u1; ++u) {
      if (known_hits.ids != nullptr) {
        const size_t i = static_cast<size_t>(v) * camera.width + u;
        if ((*known_hits.ids)[i] == known_hits.id) {
          count(u);
          continue;
        }
        const float seen = (*known_hits.depth)[i];
        if (seen <= 0 || seen > known_hits.far_depth) continue;
      }
      const Eigen::Vector3f direction = rotation * camera.RayThroughPixel(u, v);
      const int k = rays++;
      columns[k] = u;
      valid[k] = -1;
      SetOcclusionLane(k, origin, direction, &packet);
      if (rays == kPacket) cast();
    }
    if (rays > 0) cast();
  });
  return MergedRows(rows);
}

}  // namespace furn
