#include "core/render_compare.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

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

}  // namespace furn
