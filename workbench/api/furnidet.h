// The furnidet C++ API: what a program links against after `cmake --install`
// (find_package(furnidet) -> furnidet::furnidet, or pkg-config furnidet).
// Only the standard library in this header: the engine's own types, Eigen,
// PCL and libtorch stay inside libfurnidet.so.
//
// Conventions (docs/conventions.md): SI units, radians; the world has the
// floor at z = 0 and z up; a detection is a REP 103 box (its x axis the
// object's front, yaw of that axis about z, counter-clockwise).
//
//   #include <furnidet/furnidet.h>
//   furnidet::Detector detector("model.fcm");
//   for (const furnidet::Box& box : detector.DetectDepth(depth_m, camera))
//     std::printf("%s %.2f\n", box.class_name.c_str(), box.score);
//
// Errors (a model file that is not one, bad intrinsics) throw
// std::runtime_error with one line naming the file or value and the rule.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace furnidet {

// "0.1.0": the library's version (the workbench's and the Python module's).
std::string Version();

// The folder of class_map.json and the other data files the library finds
// beside itself (<prefix>/share/furnidet/data), or "" when there is none.
std::string DataDir();

// A pinhole depth camera: pixels (u, v) from the top left, optical axes.
struct Camera {
  int width = 640, height = 480;
  double fx = 580, fy = 580, cx = 319.5, cy = 239.5;
};

// A detected piece of furniture in the floor-aligned world.
struct Box {
  std::string class_name;          // chair, armchair, table, sideboard or sofa
  double score = 0;                // higher is surer (a ranking, not a probability)
  std::array<double, 3> centre{};  // the box's middle (m)
  std::array<double, 3> size{};    // along its front, its left, up (m)
  double yaw = 0;                  // of its front about z (rad, -pi..pi]
  std::string model;               // the CAD model fitted, or ""
};

// A pose as 16 numbers, row-major (four rows of a 4x4 matrix).
using Pose = std::array<double, 16>;

class Detector {
 public:
  // Loads a model file written by `workbench train`.
  explicit Detector(const std::string& model_path);
  ~Detector();
  Detector(Detector&&) noexcept;
  Detector& operator=(Detector&&) noexcept;

  // A depth image in metres (row-major, width x height; 0 or non-finite: no
  // return). With the camera's pose in a floor-aligned world it is used;
  // without, the floor is found in the scan and the boxes are in its frame.
  // Detections at the model's operating point, best first.
  std::vector<Box> DetectDepth(const std::vector<float>& depth_m,
                               const Camera& camera,
                               const std::optional<Pose>& world_from_camera = std::nullopt) const;

  // Camera-frame points (optical axes, metres; x, y, z each), unorganised.
  std::vector<Box> DetectPoints(const std::vector<std::array<float, 3>>& points,
                                const std::optional<Pose>& world_from_camera = std::nullopt) const;

  // The pose the last call used (given, or the floor it found).
  Pose LastWorldFromCamera() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Scores detections another program wrote for a dataset's frames (the
// furnidet-detections format of docs/evaluation.md) as `workbench evaluate
// --detections` does, storing the run in the dataset; returns its metrics
// by name ("mAP@10cm", "AP3D/chair@0.25", ...).
std::map<std::string, double> EvaluateDetections(const std::string& detections_path,
                                                 const std::string& db_path,
                                                 const std::string& split = "test");

}  // namespace furnidet
