#include "renderers/camera.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "core/util/error.h"

namespace furn {

void CameraIntrinsics::Check() const {
  constexpr int kMaxSize = 16384;
  Require(width > 0 && width <= kMaxSize,
          "camera width " + std::to_string(width) + " must be in 1.." + std::to_string(kMaxSize));
  Require(height > 0 && height <= kMaxSize,
          "camera height " + std::to_string(height) + " must be in 1.." + std::to_string(kMaxSize));
  // A focal length beyond 10^5 pixels is a telescope's, or a typo.
  constexpr double kMaxFocal = 1e5;
  Require(std::isfinite(fx) && fx > 0 && fx <= kMaxFocal,
          "camera fx " + std::to_string(fx) + " must be in (0, 100000] pixels");
  Require(std::isfinite(fy) && fy > 0 && fy <= kMaxFocal,
          "camera fy " + std::to_string(fy) + " must be in (0, 100000] pixels");
  // Below a pixel, a focal length is a unit mistake (metres for pixels).
  char focal[96];
  std::snprintf(
      focal, sizeof(focal), "camera focal lengths %g, %g must be at least 1 pixel", fx, fy);
  Require(fx >= 1 && fy >= 1, focal);
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

std::vector<Eigen::Vector3f> BackProject(const DepthFrame& frame, const CameraIntrinsics& camera) {
  Require(frame.width == camera.width && frame.height == camera.height,
          "depth image is " + std::to_string(frame.width) + "x" + std::to_string(frame.height) +
              " but the intrinsics are for " + std::to_string(camera.width) + "x" +
              std::to_string(camera.height));
  std::vector<Eigen::Vector3f> points;
  points.reserve(static_cast<size_t>(frame.width) * frame.height);
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const float z = frame.DepthAt(u, v);
      points.push_back(z > 0 ? Eigen::Vector3f(z * camera.RayThroughPixel(u, v))
                             : Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
    }
  }
  return points;
}

}  // namespace furn
