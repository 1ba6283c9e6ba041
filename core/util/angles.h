// Angles in the world frame (radians): one definition of wrapping, shared by
// the paper's pose fit and the learned stage.
//
//   const double yaw = WrapAngle(heading + M_PI);  // in [0, 2 pi)
#pragma once

#include <cmath>

namespace furn {

// Yaw in [0, 2 pi).
inline double WrapAngle(double radians) {
  double wrapped = std::fmod(radians, 2 * M_PI);
  if (wrapped < 0) wrapped += 2 * M_PI;
  return wrapped >= 2 * M_PI ? 0.0 : wrapped;
}

}  // namespace furn
