// The installed library from a program of your own: its version and data,
// and, given a model file, detection in a depth image (here a floor seen
// from 1.2 m, pitched down 30 degrees: the floor is found, nothing stands
// on it).
#include <furnidet/furnidet.h>

#include <cmath>
#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  std::printf("furnidet %s, data in %s\n",
              furnidet::Version().c_str(),
              furnidet::DataDir().empty() ? "(none found)" : furnidet::DataDir().c_str());
  if (argc < 2) return 0;
  try {
    const furnidet::Detector detector(argv[1]);
    const furnidet::Camera camera;  // Kinect v1: 640 x 480, f = 580
    const double height = 1.2, pitch = 30 * M_PI / 180;
    std::vector<float> depth(static_cast<size_t>(camera.width) * camera.height, 0.0f);
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        // Where the pixel's ray meets the floor (world up in the camera's
        // axes: 0, -cos pitch, -sin pitch).
        const double y = (v - camera.cy) / camera.fy;
        const double down = std::cos(pitch) * y + std::sin(pitch);
        const double z = down > 0 ? height / down : 0;
        if (z > 0 && z < 4.5)
          depth[static_cast<size_t>(v) * camera.width + u] = static_cast<float>(z);
      }
    }
    const std::vector<furnidet::Box> boxes = detector.DetectDepth(depth, camera);
    const furnidet::Pose pose = detector.LastWorldFromCamera();
    std::printf(
        "%zu detections; the camera %.2f m above the floor it found\n", boxes.size(), pose[11]);
    for (const furnidet::Box& box : boxes)
      std::printf("  %s %.2f at %.2f %.2f\n",
                  box.class_name.c_str(),
                  box.score,
                  box.centre[0],
                  box.centre[1]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 1;
  }
  return 0;
}
