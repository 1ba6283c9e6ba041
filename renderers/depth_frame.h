// What a depth sensor (ideal or simulated) produces for one view.
//
//   DepthFrame frame = renderer.Render(scene, camera, world_from_camera);
//   float z = frame.DepthAt(u, v);          // metres along the optical axis, 0
//   = no return uint16_t id = frame.IdAt(u, v);         // instance id, 0 =
//   nothing
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace furn {

struct DepthFrame {
  int width = 0;
  int height = 0;
  std::vector<float> depth;              // metres along the optical axis; 0 = no return
  std::vector<uint16_t> instance_ids;    // 0 = no object
  std::vector<Eigen::Vector3f> normals;  // camera frame, unit, facing the camera; 0 where none
                                         // (empty when the renderer was asked for none)

  void Resize(int new_width, int new_height) {
    width = new_width;
    height = new_height;
    const size_t n = static_cast<size_t>(width) * height;
    depth.assign(n, 0.0f);
    instance_ids.assign(n, 0);
    normals.assign(n, Eigen::Vector3f::Zero());
  }
  // Sets the size without clearing: for writers that fill every pixel. Keeps
  // the memory of a frame reused in a loop.
  void Reshape(int new_width, int new_height) {
    width = new_width;
    height = new_height;
    const size_t n = static_cast<size_t>(width) * height;
    depth.resize(n);
    instance_ids.resize(n);
    normals.resize(n);
  }
  size_t Index(int u, int v) const { return static_cast<size_t>(v) * width + u; }
  float DepthAt(int u, int v) const { return depth[Index(u, v)]; }
  uint16_t IdAt(int u, int v) const { return instance_ids[Index(u, v)]; }
  size_t NumValid() const {
    size_t valid = 0;
    for (float z : depth) valid += z > 0;
    return valid;
  }
};

}  // namespace furn
