// The 3-D scene view's page and script (reports/viewer/), built into the
// program so that a report folder needs nothing from the source tree.
#pragma once

namespace furn {

extern const char* const kSceneHtml;      // reports/viewer/scene.html: @TITLE@, @LIBRARY@
extern const char* const kSceneViewerJs;  // reports/viewer/scene_viewer.js

}  // namespace furn
