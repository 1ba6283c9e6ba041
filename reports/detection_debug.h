// The debug bundle of one detection run as PNGs (SPEC.md §8.8):
//   segments.png      (codebook voting) preprocessed points seen from the camera, one
//                     colour per segment;
//   heat.png          (learned voting) the points coloured by the strongest class heat
//                     under them, the maxima on the floor with their fate;
//   votes_<class>.png per-class Hough votes or learned heat (top-down) with its maxima,
//                     each marked by outcome (detected / rejected);
//   fitted.png        each detection's 3-D box, the fitted models' points and the
//                     footprints of every fit tried, over the scan from the camera;
//   topdown.png       scene points from above, fitted footprints and ground truth;
//   hypotheses.json   every hypothesis: class, position, votes, candidates, outcome;
//   scene.html        the run in 3-D (reports/scene_view.h).
//
//   WriteDetectionDebug(result, detector.model(), camera, ground_truth, "debug/");
#pragma once

#include <string>
#include <vector>

#include "core/detector/detector.h"
#include "core/model/furniture_box.h"  // GroundTruthFootprint
#include "renderers/camera.h"

namespace furn {

// What the folder's 3-D page (scene.html, reports/scene_view.h) is called
// and links to.
struct SceneViewLinks {
  std::string title = "furnidet scene";
  // The viewer's library folder relative to the page; empty: "three",
  // written beside the page (a report writes one shared folder instead).
  std::string library;
  std::string previous, next, index;  // hrefs relative to the page; empty: none
};

// `camera` projects the camera-frame points (Kinect v1 when the input had no
// intrinsics). Creates `dir`; every file is written atomically. Also writes
// the 3-D page scene.html (reports/scene_view.h). Returns the PNGs' names
// as a report shows them: fitted, topdown, segments or heat, then the vote
// maps of the model's classes.
std::vector<std::string> WriteDetectionDebug(const DetectionResult& result,
                                             const TrainedModel& model,
                                             const CameraIntrinsics& camera,
                                             const std::vector<GroundTruthFootprint>& ground_truth,
                                             const std::string& dir,
                                             const SceneViewLinks& links = SceneViewLinks{});

}  // namespace furn
