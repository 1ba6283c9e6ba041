#include "core/render_compare.h"

#include <embree3/rtcore.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>

#include "core/embree_device.h"
#include "core/error.h"

namespace furn {

std::optional<PinholeIntrinsics> IntrinsicsOfOrganisedCloud(
    const std::vector<Eigen::Vector3f>& points, int width, int height) {
  if (width <= 0 || height <= 0 || static_cast<size_t>(width) * height != points.size())
    return std::nullopt;
  // Normal equations of u = fx a + cx (a = x/z) and v = fy b + cy (b = y/z),
  // over an even subsample of the valid pixels.
  Eigen::Matrix2d au = Eigen::Matrix2d::Zero(), av = Eigen::Matrix2d::Zero();
  Eigen::Vector2d bu = Eigen::Vector2d::Zero(), bv = Eigen::Vector2d::Zero();
  int used = 0;
  const int step = std::max(1, static_cast<int>(points.size() / 20000));
  for (size_t i = 0; i < points.size(); i += step) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite() || p.z() <= 0) continue;
    const double a = p.x() / p.z(), b = p.y() / p.z();
    const double u = static_cast<double>(i % width), v = static_cast<double>(i / width);
    au += Eigen::Vector2d(a, 1) * Eigen::RowVector2d(a, 1);
    bu += Eigen::Vector2d(a, 1) * u;
    av += Eigen::Vector2d(b, 1) * Eigen::RowVector2d(b, 1);
    bv += Eigen::Vector2d(b, 1) * v;
    ++used;
  }
  if (used < 100 || std::abs(au.determinant()) < 1e-9 || std::abs(av.determinant()) < 1e-9)
    return std::nullopt;
  const Eigen::Vector2d ku = au.ldlt().solve(bu), kv = av.ldlt().solve(bv);
  PinholeIntrinsics k{ku(0), kv(0), ku(1), kv(1)};
  if (!(k.fx > 0 && k.fy > 0)) return std::nullopt;
  // A pinhole image reprojects its points onto their pixels (up to the
  // float rounding of the points).
  double error = 0;
  int checked = 0;
  for (size_t i = 0; i < points.size(); i += step) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite() || p.z() <= 0) continue;
    error += std::hypot(k.fx * p.x() / p.z() + k.cx - static_cast<double>(i % width),
                        k.fy * p.y() / p.z() + k.cy - static_cast<double>(i / width));
    ++checked;
  }
  if (error / checked > 0.5) return std::nullopt;
  return k;
}

double RenderComparison::ViolationShare() const {
  return support + violation > 0 ? static_cast<double>(violation) / (support + violation) : 0;
}

double RenderComparison::SupportShare() const {
  return drawn > 0 ? static_cast<double>(support) / drawn : 0;
}

float RenderTolerance(float z) { return 0.04f + 0.005f * z * z; }

RenderComparison CompareRendered(const std::vector<Eigen::Vector3f>& model_points,
                                 const std::vector<float>& depth,
                                 int width,
                                 int height,
                                 const PinholeIntrinsics& intrinsics,
                                 float splat_m) {
  RenderComparison result;
  if (model_points.empty() || width <= 0 || height <= 0) return result;
  // The drawing's box on the image, then a z-buffer over it only.
  struct Splat {
    float u, v, z, radius;
  };
  std::vector<Splat> splats;
  splats.reserve(model_points.size());
  float u0 = std::numeric_limits<float>::max(), v0 = u0, u1 = -u0, v1 = -u0;
  for (const Eigen::Vector3f& p : model_points) {
    if (p.z() <= 0.1f) continue;  // behind or at the sensor
    const float u = static_cast<float>(intrinsics.fx * p.x() / p.z() + intrinsics.cx);
    const float v = static_cast<float>(intrinsics.fy * p.y() / p.z() + intrinsics.cy);
    const float radius = std::max(0.5f, static_cast<float>(intrinsics.fx) * 0.6f * splat_m / p.z());
    if (u + radius < 0 || v + radius < 0 || u - radius >= width || v - radius >= height) continue;
    splats.push_back({u, v, p.z(), radius});
    u0 = std::min(u0, u - radius);
    v0 = std::min(v0, v - radius);
    u1 = std::max(u1, u + radius);
    v1 = std::max(v1, v + radius);
  }
  if (splats.empty()) return result;
  const int left = std::max(0, static_cast<int>(std::floor(u0)));
  const int top = std::max(0, static_cast<int>(std::floor(v0)));
  const int right = std::min(width - 1, static_cast<int>(std::ceil(u1)));
  const int bottom = std::min(height - 1, static_cast<int>(std::ceil(v1)));
  const int box_w = right - left + 1, box_h = bottom - top + 1;
  std::vector<float> zbuffer(static_cast<size_t>(box_w) * box_h,
                             std::numeric_limits<float>::infinity());
  for (const Splat& s : splats) {
    const int r = static_cast<int>(std::ceil(s.radius));
    const int cu = static_cast<int>(std::lround(s.u)), cv = static_cast<int>(std::lround(s.v));
    for (int v = std::max(top, cv - r); v <= std::min(bottom, cv + r); ++v) {
      for (int u = std::max(left, cu - r); u <= std::min(right, cu + r); ++u) {
        const float du = u - s.u, dv = v - s.v;
        if (du * du + dv * dv > s.radius * s.radius) continue;
        float& z = zbuffer[static_cast<size_t>(v - top) * box_w + (u - left)];
        z = std::min(z, s.z);
      }
    }
  }
  for (int v = top; v <= bottom; ++v) {
    for (int u = left; u <= right; ++u) {
      const float model_z = zbuffer[static_cast<size_t>(v - top) * box_w + (u - left)];
      if (!std::isfinite(model_z)) continue;
      ++result.drawn;
      const float seen = depth[static_cast<size_t>(v) * width + u];
      if (!std::isfinite(seen) || seen <= 0) {
        ++result.unknown;
        continue;
      }
      const float tolerance = RenderTolerance(model_z);
      if (seen > model_z + tolerance) {
        ++result.violation;
      } else if (seen < model_z - tolerance) {
        ++result.occluded;
      } else {
        ++result.support;
      }
    }
  }
  return result;
}

struct ModelMeshCaster::Impl {
  const std::vector<TriangleMesh>* meshes = nullptr;
  std::vector<RTCScene> scenes;  // null until built
  std::unique_ptr<std::once_flag[]> built;

  RTCScene SceneOf(int model) {
    std::call_once(built[model], [&] {
      const TriangleMesh& mesh = (*meshes)[model];
      RTCScene scene = rtcNewScene(SharedEmbreeDevice());
      if (!mesh.Empty()) {
        RTCGeometry geometry = rtcNewGeometry(SharedEmbreeDevice(), RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry,
                                                                     RTC_BUFFER_TYPE_VERTEX,
                                                                     0,
                                                                     RTC_FORMAT_FLOAT3,
                                                                     3 * sizeof(float),
                                                                     mesh.vertices.size()));
        for (size_t i = 0; i < mesh.vertices.size(); ++i)
          Eigen::Map<Eigen::Vector3f>(vertices + 3 * i) = mesh.vertices[i];
        auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry,
                                                                       RTC_BUFFER_TYPE_INDEX,
                                                                       0,
                                                                       RTC_FORMAT_UINT3,
                                                                       3 * sizeof(unsigned),
                                                                       mesh.triangles.size()));
        std::memcpy(indices, mesh.triangles.data(), mesh.triangles.size() * 3 * sizeof(unsigned));
        rtcCommitGeometry(geometry);
        rtcAttachGeometry(scene, geometry);
        rtcReleaseGeometry(geometry);
      }
      rtcCommitScene(scene);
      scenes[model] = scene;
    });
    return scenes[model];
  }
};

ModelMeshCaster::ModelMeshCaster(const std::vector<TriangleMesh>* meshes)
    : impl_(std::make_unique<Impl>()) {
  impl_->meshes = meshes;
  impl_->scenes.assign(meshes->size(), nullptr);
  impl_->built = std::make_unique<std::once_flag[]>(meshes->size());
}

ModelMeshCaster::~ModelMeshCaster() {
  for (RTCScene scene : impl_->scenes) {
    if (scene != nullptr) rtcReleaseScene(scene);
  }
}

size_t ModelMeshCaster::NumMeshes() const { return impl_->meshes->size(); }

RenderComparison ModelMeshCaster::Compare(int model,
                                          const Eigen::Isometry3f& camera_from_model,
                                          const std::vector<float>& depth,
                                          int width,
                                          int height,
                                          const PinholeIntrinsics& intrinsics,
                                          float min_model_z,
                                          int max_rays) const {
  Require(model >= 0 && static_cast<size_t>(model) < impl_->meshes->size(),
          "render-and-compare of model " + std::to_string(model) + ": no such mesh");
  RenderComparison result;
  const TriangleMesh& mesh = (*impl_->meshes)[model];
  if (mesh.Empty() || width <= 0 || height <= 0 ||
      depth.size() != static_cast<size_t>(width) * height)
    return result;
  // The image box of the posed bounding box; the whole image when a corner
  // is behind the camera.
  const Box3 box = BoundingBox(mesh);
  float u0 = std::numeric_limits<float>::max(), v0 = u0, u1 = -u0, v1 = -u0;
  bool behind = false;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3f p =
        camera_from_model * Eigen::Vector3f((corner & 1) ? box.max.x() : box.min.x(),
                                            (corner & 2) ? box.max.y() : box.min.y(),
                                            (corner & 4) ? box.max.z() : box.min.z());
    if (p.z() <= 0.05f) {
      behind = true;
      break;
    }
    const float u = static_cast<float>(intrinsics.fx * p.x() / p.z() + intrinsics.cx);
    const float v = static_cast<float>(intrinsics.fy * p.y() / p.z() + intrinsics.cy);
    u0 = std::min(u0, u);
    v0 = std::min(v0, v);
    u1 = std::max(u1, u);
    v1 = std::max(v1, v);
  }
  const int left = behind ? 0 : std::max(0, static_cast<int>(std::floor(u0)));
  const int top = behind ? 0 : std::max(0, static_cast<int>(std::floor(v0)));
  const int right = behind ? width - 1 : std::min(width - 1, static_cast<int>(std::ceil(u1)));
  const int bottom = behind ? height - 1 : std::min(height - 1, static_cast<int>(std::ceil(v1)));
  if (right < left || bottom < top) return result;
  const double area = static_cast<double>(right - left + 1) * (bottom - top + 1);
  const int stride =
      std::max(1, static_cast<int>(std::ceil(std::sqrt(area / std::max(1, max_rays)))));

  RTCScene scene = impl_->SceneOf(model);
  const Eigen::Isometry3f model_from_camera = camera_from_model.inverse();
  const Eigen::Vector3f origin = model_from_camera.translation();
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  for (int v = top; v <= bottom; v += stride) {
    for (int u = left; u <= right; u += stride) {
      // A camera ray with unit z, so the hit distance is the camera depth.
      const Eigen::Vector3f direction =
          model_from_camera.linear() *
          Eigen::Vector3f(static_cast<float>((u - intrinsics.cx) / intrinsics.fx),
                          static_cast<float>((v - intrinsics.cy) / intrinsics.fy),
                          1.0f);
      RTCRayHit hit;
      hit.ray.org_x = origin.x();
      hit.ray.org_y = origin.y();
      hit.ray.org_z = origin.z();
      hit.ray.dir_x = direction.x();
      hit.ray.dir_y = direction.y();
      hit.ray.dir_z = direction.z();
      hit.ray.tnear = 0.05f;
      hit.ray.tfar = std::numeric_limits<float>::infinity();
      hit.ray.time = 0;
      hit.ray.mask = 0xFFFFFFFFu;
      hit.ray.id = 0;
      hit.ray.flags = 0;
      hit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      hit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &context, &hit);
      if (hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
      if (origin.z() + hit.ray.tfar * direction.z() < min_model_z) continue;
      const float model_z = hit.ray.tfar;
      ++result.drawn;
      const float seen = depth[static_cast<size_t>(v) * width + u];
      if (!std::isfinite(seen) || seen <= 0) {
        ++result.unknown;
        continue;
      }
      const float tolerance = RenderTolerance(model_z);
      if (seen > model_z + tolerance) {
        ++result.violation;
      } else if (seen < model_z - tolerance) {
        ++result.occluded;
      } else {
        ++result.support;
      }
    }
  }
  return result;
}

}  // namespace furn
