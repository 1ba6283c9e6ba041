// `dataset convert-nyu`: NYU Depth V2's labelled frames (Kinect v1, 1449
// frames of 464 rooms, NYU-40 class masks) turned into a labelled real set
// (formats/real_labels.h) that `dataset import-real` reads: one 16-bit depth
// PNG per frame, the floor plane fitted to the frame's floor pixels as the
// label frame, and furniture instances derived from the class masks and the
// depth. Only frames of the official train split (`trainNdxs` of NYU's
// splits.mat) are converted, and never the held-out ranges below.
//
//   NyuConvertOptions options;
//   options.source_dir = "refinenet_pytorch";  // data/nyu_depths, nyu_labels40, nyu_images
//   options.splits_path = "splits.mat";
//   options.out_dir = "nyu-real";
//   NyuConvertSummary summary = ConvertNyu(options);
//   // then: workbench dataset import-real nyu-real/labels.json --out nyu.db
//
// The frames' licence is research use: the output stays on the user's disk
// (docs/real-scans.md, tools/fetch_nyu.sh).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/model/furniture_class.h"

namespace furn {

// Labelled indices (1-based) never converted even when a split names them:
// kept for evaluation nobody here sees.
inline constexpr int kNyuHeldOutRanges[][2] = {{1330, 1350}, {1400, 1420}};
bool IsNyuHeldOut(int labelled_index);

// The source as the public repository markshih91/refinenet_pytorch holds it
// (checked on its frames; docs/real-scans.md): 640x480, mirrored left-right,
// file k is labelled index k + 1, depth 8-bit with metres = (value + 0.5) *
// kNyuDepthStep (filled, no holes), labels = NYU-40 id - 1 where 39 is
// otherprop and also every unlabelled pixel (the image border is 39).
inline constexpr int kNyuWidth = 640, kNyuHeight = 480;
inline constexpr double kNyuDepthStep = 0.039198;
// The colour camera's intrinsics (NYU toolbox camera_params.m, 0-based,
// un-mirrored); the labelled depth is registered to it.
inline constexpr double kNyuFx = 518.858, kNyuFy = 519.470, kNyuCx = 324.58, kNyuCy = 252.74;

struct NyuDeriveOptions {
  int min_floor_pixels = 3000;         // fewer floor pixels: the frame is left out (no label frame)
  double floor_inlier_m = 0.06;        // plane fit's inlier band (m; 1.5 depth steps)
  double min_camera_height_m = 0.3;    // a fitted floor outside these camera heights (m) ...
  double max_camera_height_m = 2.5;    // ... is not trusted and the frame is left out
  double depth_jump_m = 0.10;          // neighbours of one class join when depth differs less (m)
  double depth_jump_fraction = 0.04;   // ... or less than this share of their depth
  int min_component_pixels = 150;      // smaller pieces of a mask are dropped
  double merge_gap_m = 0.05;           // pieces of one class this close on the floor merge ...
  int min_object_pixels = 1200;        // an instance with fewer pixels is ignored (not a target)
  double max_range_m = 3.5;            // an instance farther (floor distance, m) is ignored
  double min_top_m = 0.3;              // an instance whose top is lower (m) is ignored
  double border_band_px = 8;           // pixels this close to the image edge ...
  double max_border_share = 0.08;      // ... above this share of an instance's: cut off, ignored
  double armchair_max_length_m = 1.2;  // a "sofa" whose longer side is shorter: an armchair

  void Check() const;
};

// One derived instance: a footprint in the label frame (z up, floor at 0).
struct NyuInstance {
  FurnitureClass furniture_class = FurnitureClass::kChair;
  int nyu_class = 0;    // NYU-40 id
  double x = 0, y = 0;  // footprint centre of the visible part (m)
  double yaw = 0;       // of the footprint rectangle's long side (not the front)
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  // footprint sides and top height (m)
  int pixels = 0;
  double range_m = 0;              // floor distance from the camera to the centre
  std::string ignored;             // why it is not a target; empty for targets
  std::vector<int> pixel_indices;  // row-major pixels of its mask
};

// A frame's derived labels, or why it has none.
struct NyuFrameLabels {
  bool usable = false;
  std::string reason;  // when not usable
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  int floor_pixels = 0;
  double floor_rms_m = 0;  // of the floor pixels about the fitted plane
  std::vector<NyuInstance> instances;
};

// Derives the floor and instances of one frame, un-mirrored already:
// `depth_m` row-major metres (0: none), `labels` row-major NYU-40 ids - 1.
NyuFrameLabels DeriveNyuLabels(const std::vector<float>& depth_m,
                               const std::vector<uint8_t>& labels,
                               const NyuDeriveOptions& options);

struct NyuConvertOptions {
  std::string source_dir;   // holds data/nyu_depths, data/nyu_labels40 (data/nyu_images optional)
  std::string splits_path;  // NYU's splits.mat
  std::string out_dir;      // new folder: labels.json, depth/, README.md, overlays/ (optional)
  int max_frames = 0;       // at most this many (every k-th train frame); 0: all
  bool overlays = false;    // an RGB overlay PNG per frame with its derived instances
  // The 8-bit depth's 3.9 cm steps make terraces of every surface (normals
  // and segments of steps, not of furniture): each pixel takes the mean of
  // the values within one step of its own in a (2r+1)^2 window (0: off).
  int dequantise_radius = 5;
  NyuDeriveOptions derive;

  void Check() const;
};

// Pixel (u, v) of the source's 8-bit depth (`steps`, row-major, 640x480,
// un-mirrored) in metres, de-quantised as above (radius 0: the step's
// centre); 0 where the source has no depth.
float DequantisedNyuDepth(const std::vector<uint8_t>& steps, int u, int v, int radius);

struct NyuConvertSummary {
  int train_frames = 0;  // in the split, held-out ranges removed
  int frames = 0, frames_left_out = 0;
  int targets = 0, ignored = 0;                 // instances
  std::map<std::string, int> left_out_reasons;  // frames left out, by why
};

// Refuses an existing `out_dir`; writes it whole or not at all.
NyuConvertSummary ConvertNyu(const NyuConvertOptions& options);

}  // namespace furn
