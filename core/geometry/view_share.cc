#include "core/geometry/view_share.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/geometry/render_compare.h"  // PinholeIntrinsics

namespace furn {

ViewFrustum ViewFrustum::OfPinhole(const PinholeIntrinsics& k, int width, int height) {
  ViewFrustum view;
  view.left = (-0.5 - k.cx) / k.fx;
  view.right = (width - 0.5 - k.cx) / k.fx;
  view.top = (-0.5 - k.cy) / k.fy;
  view.bottom = (height - 0.5 - k.cy) / k.fy;
  return view;
}

std::optional<ViewFrustum> ViewFrustum::OfPoints(const std::vector<Eigen::Vector3f>& points) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  ViewFrustum view{kInf, -kInf, kInf, -kInf};
  int used = 0;
  for (const Eigen::Vector3f& p : points) {
    if (!p.allFinite() || p.z() <= 0) continue;
    const double u = p.x() / p.z(), v = p.y() / p.z();
    view.left = std::min(view.left, u);
    view.right = std::max(view.right, u);
    view.top = std::min(view.top, v);
    view.bottom = std::max(view.bottom, v);
    ++used;
  }
  if (used < 2) return std::nullopt;
  // Half-open bounds: the extreme points themselves are in view.
  view.right = std::nextafter(view.right, kInf);
  view.bottom = std::nextafter(view.bottom, kInf);
  return view;
}

bool ViewFrustum::Contains(const Eigen::Vector3d& p) const {
  if (!(p.z() > 0)) return false;
  const double u = p.x() / p.z(), v = p.y() / p.z();
  return u >= left && u < right && v >= top && v < bottom;
}

double ShareOfBoxInView(const ViewFrustum& view,
                        const Eigen::Isometry3d& camera_from_box,
                        const Eigen::Vector3d& low,
                        const Eigen::Vector3d& high) {
  constexpr int kAcross = 8, kUp = 4;
  const Eigen::Vector3d size = high - low;
  int inside = 0;
  for (int i = 0; i < kAcross; ++i) {
    for (int j = 0; j < kAcross; ++j) {
      for (int k = 0; k < kUp; ++k) {
        const Eigen::Vector3d step((i + 0.5) / kAcross, (j + 0.5) / kAcross, (k + 0.5) / kUp);
        inside += view.Contains(camera_from_box * (low + step.cwiseProduct(size)));
      }
    }
  }
  return static_cast<double>(inside) / (kAcross * kAcross * kUp);
}

}  // namespace furn
