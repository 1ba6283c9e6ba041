#include "workbench/pipelines/render_showcase.h"

#include "core/geometry/conventions.h"

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "renderers/kinect_simulator.h"
#include "reports/frame_preview.h"
#include "scenes/showcase_scene.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/point_cloud_file.h"

namespace furn {

RenderOutputs RenderShowcase(const CadModel& model, const RenderShowcaseOptions& options) {
  Require(!options.out_dir.empty(), "render: --out directory is required");
  std::error_code ec;
  std::filesystem::create_directories(options.out_dir, ec);
  Require(std::filesystem::is_directory(options.out_dir, ec),
          options.out_dir + ": cannot create the output directory");
  ShowcaseOptions showcase;
  showcase.yaw_rad = options.yaw_deg * M_PI / 180;
  const Scene scene = MakeShowcaseScene(model, showcase);
  const Eigen::Isometry3d world_from_camera =
      ShowcaseCamera(options.distance_m, options.height_m, options.pitch_deg);
  std::unique_ptr<DepthRenderer> renderer = MakeRenderer(options.renderer);
  const KinectCapture capture = CaptureKinect(
      renderer.get(), scene, options.camera, world_from_camera, options.noise, options.seed);

  const std::filesystem::path dir(options.out_dir);
  RenderOutputs outputs;
  auto path = [&](const char* name) {
    outputs.files.push_back((dir / name).string());
    return outputs.files.back();
  };
  WriteDepthPng(capture.ideal, path("depth_ideal.png"));
  WriteDepthPng(capture.noisy, path("depth_noisy.png"));
  WriteIdPng(capture.ideal, path("ids_ideal.png"));
  WriteIdPng(capture.noisy, path("ids_noisy.png"));
  WriteOrganizedPcd(capture.ideal, options.camera, path("cloud_ideal.pcd"));
  WriteOrganizedPcd(capture.noisy, options.camera, path("cloud_noisy.pcd"));
  WritePreviewPng(
      {{&capture.ideal, PreviewPanel::Kind::kDepth, "ideal depth (" + renderer->Name() + ")"},
       {&capture.noisy, PreviewPanel::Kind::kDepth, "noisy depth (Kinect v1 model)"},
       {&capture.ideal, PreviewPanel::Kind::kShadedDepth, "ideal, shaded"},
       {&capture.noisy, PreviewPanel::Kind::kShadedDepth, "noisy, shaded"},
       {&capture.ideal, PreviewPanel::Kind::kIds, "ideal instance ids"},
       {&capture.noisy, PreviewPanel::Kind::kIds, "noisy instance ids"}},
      2,
      path("preview.png"));
  nlohmann::ordered_json camera_json{{"model", model.id},
                                     {"renderer", renderer->Name()},
                                     {"seed", options.seed},
                                     {"intrinsics",
                                      {{"width", options.camera.width},
                                       {"height", options.camera.height},
                                       {"fx", options.camera.fx},
                                       {"fy", options.camera.fy},
                                       {"cx", options.camera.cx},
                                       {"cy", options.camera.cy}}},
                                     {"depth_units_per_metre", 1000},
                                     {"format", 2},  // 1: a flat column-major pose
                                     {"world_from_camera", PoseRows(world_from_camera)}};
  WriteFileAtomically(path("camera.json"), camera_json.dump(2) + "\n");
  outputs.ideal_valid = capture.ideal.NumValid();
  outputs.noisy_valid = capture.noisy.NumValid();
  return outputs;
}

}  // namespace furn
