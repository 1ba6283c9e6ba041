// An interactive 3-D view of one detection run: a page that opens offline
// from its folder (three.js from Debian's libjs-three, copied beside it) and
// shows the frame's points, the floor grid, the camera, the ground-truth
// boxes, the detections' boxes and fitted models, the learned heat on the
// floor and every maximum; orbit, pan, zoom, a toggle per layer, a click on
// a box or maximum says what it is and, for a missed object, the funnel stage
// it was lost at.
//
//   dir/scene.html      the page (title, links to the previous/next frame)
//   dir/scene_data.js   the frame as `window.FURN_SCENE = {...}`: points as
//                       little-endian int16 millimetres from an origin, base64
//   <library>/          three.min.js, OrbitControls.js, scene_viewer.js,
//                       VERSION (three.js release and licence)
//
//   WriteSceneView(result, model, camera, truth, "debug/", SceneViewLinks{});
#pragma once

#include <string>
#include <vector>

#include "core/detector/detector.h"
#include "renderers/camera.h"
#include "reports/detection_debug.h"

namespace furn {

// The most points a page carries (every k-th point beyond it): ~1 MB of data.
constexpr size_t kSceneMaxPoints = 150000;

// Writes dir/scene.html and dir/scene_data.js (and dir/three/ when
// links.library is empty), each atomically. Throws InputError when three.js
// is not installed (names the package).
void WriteSceneView(const DetectionResult& result,
                    const TrainedModel& model,
                    const CameraIntrinsics& camera,
                    const std::vector<GroundTruthFootprint>& ground_truth,
                    const std::string& dir,
                    const SceneViewLinks& links);

// Copies three.js, its orbit controls and the viewer script into `dir`.
void WriteSceneLibrary(const std::string& dir);

}  // namespace furn
