#include "core/geometry/box_iou.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace furn {
namespace {

using Polygon = std::vector<Eigen::Vector2d>;

// The footprint's corners, counter-clockwise (x along the box's yaw).
Polygon Footprint(const OrientedBox& box) {
  const Eigen::Vector2d centre = box.centre.head<2>();
  const Eigen::Vector2d along(std::cos(box.yaw), std::sin(box.yaw));
  const Eigen::Vector2d across(-along.y(), along.x());
  const Eigen::Vector2d hx = along * (box.size.x() / 2), hy = across * (box.size.y() / 2);
  return {centre - hx - hy, centre + hx - hy, centre + hx + hy, centre - hx + hy};
}

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// `subject` clipped by the half-plane left of the edge from `p` to `q`.
Polygon ClipByEdge(const Polygon& subject, const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
  Polygon out;
  const Eigen::Vector2d edge = q - p;
  auto inside = [&](const Eigen::Vector2d& v) { return Cross(edge, v - p) >= 0; };
  for (size_t i = 0; i < subject.size(); ++i) {
    const Eigen::Vector2d& current = subject[i];
    const Eigen::Vector2d& next = subject[(i + 1) % subject.size()];
    const bool in_current = inside(current), in_next = inside(next);
    if (in_current) out.push_back(current);
    if (in_current != in_next) {
      // Where the segment current -> next crosses the edge's line.
      const double denominator = Cross(edge, next - current);
      const double t = Cross(edge, p - current) / denominator;
      out.push_back(current + t * (next - current));
    }
  }
  return out;
}

double Area(const Polygon& polygon) {
  double twice = 0;
  for (size_t i = 0; i < polygon.size(); ++i)
    twice += Cross(polygon[i], polygon[(i + 1) % polygon.size()]);
  return std::abs(twice) / 2;
}

double ZOverlap(const OrientedBox& a, const OrientedBox& b) {
  const double low = std::max(a.centre.z() - a.size.z() / 2, b.centre.z() - b.size.z() / 2);
  const double high = std::min(a.centre.z() + a.size.z() / 2, b.centre.z() + b.size.z() / 2);
  return std::max(0.0, high - low);
}

bool Empty(const OrientedBox& box, bool with_height) {
  return !(box.size.x() > 0 && box.size.y() > 0 && (!with_height || box.size.z() > 0));
}

}  // namespace

double FootprintIntersectionArea(const OrientedBox& a, const OrientedBox& b) {
  if (Empty(a, false) || Empty(b, false)) return 0;
  Polygon clipped = Footprint(a);
  const Polygon clip = Footprint(b);
  for (size_t i = 0; i < clip.size() && !clipped.empty(); ++i)
    clipped = ClipByEdge(clipped, clip[i], clip[(i + 1) % clip.size()]);
  return clipped.size() < 3 ? 0.0 : Area(clipped);
}

double BevIou(const OrientedBox& a, const OrientedBox& b) {
  if (Empty(a, false) || Empty(b, false)) return 0;
  const double inter = FootprintIntersectionArea(a, b);
  const double uni = a.size.x() * a.size.y() + b.size.x() * b.size.y() - inter;
  return uni > 0 ? std::clamp(inter / uni, 0.0, 1.0) : 0.0;
}

double Iou3d(const OrientedBox& a, const OrientedBox& b) {
  if (Empty(a, true) || Empty(b, true)) return 0;
  const double inter = FootprintIntersectionArea(a, b) * ZOverlap(a, b);
  const double uni = a.size.prod() + b.size.prod() - inter;
  return uni > 0 ? std::clamp(inter / uni, 0.0, 1.0) : 0.0;
}

}  // namespace furn
