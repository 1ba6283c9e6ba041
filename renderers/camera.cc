#include "renderers/camera.h"

#include <cmath>
#include <sstream>

#include "core/error.h"

namespace furn {

void CameraIntrinsics::Check() const {
  constexpr int kMaxSize = 16384;
  Require(width > 0 && width <= kMaxSize,
          "camera width " + std::to_string(width) + " must be in 1.." + std::to_string(kMaxSize));
  Require(height > 0 && height <= kMaxSize,
          "camera height " + std::to_string(height) + " must be in 1.." + std::to_string(kMaxSize));
  Require(std::isfinite(fx) && fx > 0, "camera fx " + std::to_string(fx) + " must be > 0");
  Require(std::isfinite(fy) && fy > 0, "camera fy " + std::to_string(fy) + " must be > 0");
  Require(std::isfinite(cx) && cx >= 0 && cx <= width,
          "camera cx " + std::to_string(cx) + " must lie in the image width 0.." +
              std::to_string(width));
  Require(std::isfinite(cy) && cy >= 0 && cy <= height,
          "camera cy " + std::to_string(cy) + " must lie in the image height 0.." +
              std::to_string(height));
}

std::string CameraIntrinsics::ToString() const {
  std::ostringstream text;
  text << width << "x" << height << " fx=" << fx << " fy=" << fy << " cx=" << cx << " cy=" << cy;
  return text.str();
}

}  // namespace furn
