#include "core/geometry/render_compare.h"

#include <embree3/rtcore.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>

#include "core/geometry/embree_device.h"
#include "core/util/error.h"

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

namespace {

// The 3 x 4 projection of an organised cloud's pixels by the normalised DLT
// (Hartley: centred, mean distance sqrt(2) in the image and sqrt(3) in
// space), over `used` pixels; nullopt when they are degenerate.
std::optional<Eigen::Matrix<double, 3, 4>> ProjectionByDlt(
    const std::vector<Eigen::Vector3f>& points, int width, const std::vector<int>& used) {
  Eigen::Vector3d mean_x = Eigen::Vector3d::Zero();
  Eigen::Vector2d mean_u = Eigen::Vector2d::Zero();
  for (int i : used) {
    mean_x += points[i].cast<double>();
    mean_u += Eigen::Vector2d(i % width, i / width);
  }
  mean_x /= used.size();
  mean_u /= used.size();
  double spread_x = 0, spread_u = 0;
  for (int i : used) {
    spread_x += (points[i].cast<double>() - mean_x).norm();
    spread_u += (Eigen::Vector2d(i % width, i / width) - mean_u).norm();
  }
  spread_x /= used.size();
  spread_u /= used.size();
  if (spread_x < 1e-6 || spread_u < 1e-6) return std::nullopt;
  const double sx = std::sqrt(3.0) / spread_x, su = std::sqrt(2.0) / spread_u;
  Eigen::MatrixXd a(2 * used.size(), 12);
  for (size_t r = 0; r < used.size(); ++r) {
    const int i = used[r];
    const Eigen::Vector3d x = (points[i].cast<double>() - mean_x) * sx;
    const Eigen::Vector4d X(x.x(), x.y(), x.z(), 1);
    const double u = (i % width - mean_u.x()) * su, v = (i / width - mean_u.y()) * su;
    a.row(2 * r) << X.transpose(), Eigen::RowVector4d::Zero(), -u * X.transpose();
    a.row(2 * r + 1) << Eigen::RowVector4d::Zero(), X.transpose(), -v * X.transpose();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd p = svd.matrixV().col(11);
  Eigen::Matrix<double, 3, 4> normalised;
  normalised << p.segment<4>(0).transpose(), p.segment<4>(4).transpose(),
      p.segment<4>(8).transpose();
  // Undo the normalisations: P = Tu^-1 P' Tx.
  Eigen::Matrix3d tu_inverse = Eigen::Matrix3d::Identity();
  tu_inverse(0, 0) = tu_inverse(1, 1) = 1 / su;
  tu_inverse.topRightCorner<2, 1>() = mean_u;
  Eigen::Matrix4d tx = Eigen::Matrix4d::Identity();
  tx.topLeftCorner<3, 3>() *= sx;
  tx.topRightCorner<3, 1>() = -sx * mean_x;
  Eigen::Matrix<double, 3, 4> projection = tu_inverse * normalised * tx;
  // Points in front of the camera have positive depth.
  const Eigen::Vector4d first(points[used[0]].x(), points[used[0]].y(), points[used[0]].z(), 1);
  if ((projection * first).z() < 0) projection = -projection;
  return projection;
}

// K [R | -R c] from a projection by RQ decomposition (the QR of the reversed
// transpose): positive focal lengths, a proper rotation, no skew; nullopt
// for anything else.
std::optional<OrganisedCloudCamera> DecomposeProjection(
    const Eigen::Matrix<double, 3, 4>& projection) {
  const Eigen::Matrix3d m = projection.leftCols<3>();
  if (std::abs(m.determinant()) < 1e-12) return std::nullopt;
  Eigen::Matrix3d flip = Eigen::Matrix3d::Zero();
  flip(0, 2) = flip(1, 1) = flip(2, 0) = 1;
  const Eigen::HouseholderQR<Eigen::Matrix3d> qr((flip * m).transpose());
  const Eigen::Matrix3d q = qr.householderQ();
  const Eigen::Matrix3d upper = qr.matrixQR().triangularView<Eigen::Upper>();
  Eigen::Matrix3d k = flip * upper.transpose() * flip;
  Eigen::Matrix3d r = flip * q.transpose();
  for (int c = 0; c < 3; ++c) {
    if (k(c, c) < 0) {
      k.col(c) = -k.col(c);
      r.row(c) = -r.row(c);
    }
  }
  if (r.determinant() < 0) return std::nullopt;
  const double scale = k(2, 2);
  k /= scale;
  OrganisedCloudCamera camera;
  camera.intrinsics = {k(0, 0), k(1, 1), k(0, 2), k(1, 2)};
  if (!(camera.intrinsics.fx > 0 && camera.intrinsics.fy > 0) ||
      std::abs(k(0, 1)) > 1e-3 * k(0, 0))  // a skewed camera is not a depth sensor's
    return std::nullopt;
  const Eigen::Vector3d centre = -m.inverse() * projection.col(3);
  camera.world_from_camera.linear() = r.transpose();
  camera.world_from_camera.translation() = centre;
  return camera;
}

}  // namespace

std::optional<OrganisedCloudCamera> CameraOfOrganisedCloud(
    const std::vector<Eigen::Vector3f>& points, int width, int height) {
  if (width <= 0 || height <= 0 || static_cast<size_t>(width) * height != points.size())
    return std::nullopt;
  // An even subsample of the valid pixels.
  std::vector<int> used;
  const int step = std::max(1, static_cast<int>(points.size() / 4000));
  for (size_t i = 0; i < points.size(); i += step) {
    if (points[i].allFinite()) used.push_back(static_cast<int>(i));
  }
  if (used.size() < 50) return std::nullopt;
  const std::optional<Eigen::Matrix<double, 3, 4>> projection =
      ProjectionByDlt(points, width, used);
  if (!projection) return std::nullopt;
  const std::optional<OrganisedCloudCamera> camera = DecomposeProjection(*projection);
  if (!camera) return std::nullopt;
  // The camera reprojects the points onto their pixels.
  const Eigen::Isometry3d camera_from_world = camera->world_from_camera.inverse();
  double error = 0;
  for (int i : used) {
    const Eigen::Vector3d c = camera_from_world * points[i].cast<double>();
    if (c.z() <= 0) return std::nullopt;
    error += std::hypot(camera->intrinsics.fx * c.x() / c.z() + camera->intrinsics.cx - i % width,
                        camera->intrinsics.fy * c.y() / c.z() + camera->intrinsics.cy - i / width);
  }
  if (error / used.size() > 1.0) return std::nullopt;
  return camera;
}

double RenderComparison::ViolationShare() const {
  return support + violation > 0 ? static_cast<double>(violation) / (support + violation) : 0;
}

double RenderComparison::SupportShare() const {
  return drawn > 0 ? static_cast<double>(support) / drawn : 0;
}

float RenderTolerance(float z) { return 0.04f + 0.005f * z * z; }

Visibility VisibilityInScan(const std::vector<Eigen::Vector3f>& points,
                            int width,
                            int height,
                            const PinholeIntrinsics& intrinsics,
                            const Eigen::Vector3d& point_in_camera) {
  const Eigen::Vector3d& p = point_in_camera;
  constexpr double kNearestM = 0.1;
  if (p.z() < kNearestM || static_cast<size_t>(width) * height != points.size())
    return Visibility::kUnknown;
  const double u = std::floor(intrinsics.fx * p.x() / p.z() + intrinsics.cx);
  const double v = std::floor(intrinsics.fy * p.y() / p.z() + intrinsics.cy);
  if (!(u >= 0 && v >= 0 && u < width && v < height)) return Visibility::kUnknown;
  const Eigen::Vector3f& seen = points[static_cast<size_t>(v) * width + static_cast<size_t>(u)];
  // No return: a grazing, dark or far surface, or nothing; it says nothing.
  if (!seen.allFinite() || seen.z() <= 0) return Visibility::kUnknown;
  const double tolerance = RenderTolerance(static_cast<float>(p.z()));
  if (seen.z() > p.z() + tolerance) return Visibility::kFree;
  if (seen.z() < p.z() - tolerance) return Visibility::kHidden;
  return Visibility::kOccupied;
}

namespace {

// One drawn pixel: the model's depth there against what the sensor saw.
void CountPixel(float model_z, float seen, RenderComparison* result) {
  ++result->drawn;
  if (!std::isfinite(seen) || seen <= 0) {
    ++result->unknown;
    return;
  }
  const float tolerance = RenderTolerance(model_z);
  if (seen > model_z + tolerance) {
    ++result->violation;
  } else if (seen < model_z - tolerance) {
    ++result->occluded;
  } else {
    ++result->support;
  }
}

}  // namespace

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
      CountPixel(model_z, depth[static_cast<size_t>(v) * width + u], &result);
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
      if (!mesh.Empty()) AttachTriangles(mesh, Eigen::Isometry3f::Identity(), scene);
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
      CountPixel(model_z, depth[static_cast<size_t>(v) * width + u], &result);
    }
  }
  return result;
}

}  // namespace furn
