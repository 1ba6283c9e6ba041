// What a scan says about one point of the room: seen free, seen occupied,
// hidden behind a surface, or unknown. The verification of a fit
// (render_compare.h) and the learned extent fit (core/learned/bev_extent.h)
// both ask it.
//
//   const VisibilityTest seen = [&](const Eigen::Vector3d& world) { ... };
//   if (seen(point) == Visibility::kFree) { ... }
#pragma once

#include <Eigen/Core>
#include <functional>

namespace furn {

enum class Visibility {
  kFree,      // a ray of the scan passed through it
  kOccupied,  // the scan saw a surface there
  kHidden,    // the scan saw a surface in front of it
  kUnknown,   // out of view, or no return on its ray: the scan says nothing
};
using VisibilityTest = std::function<Visibility(const Eigen::Vector3d& world)>;

}  // namespace furn
