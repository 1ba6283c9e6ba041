#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/file_util.h"
#include "renderers/frame_io.h"
#include "renderers/kinect_simulator.h"
#include "scenes/showcase_scene.h"
#include "workbench/cli_common.h"
#include "workbench/commands.h"
#include "workbench/render_command.h"

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
                                     {"world_from_camera",
                                      std::vector<double>(world_from_camera.matrix().data(),
                                                          world_from_camera.matrix().data() + 16)},
                                     {"world_from_camera_layout", "4x4 column-major"}};
  WriteFileAtomically(path("camera.json"), camera_json.dump(2) + "\n");
  outputs.ideal_valid = capture.ideal.NumValid();
  outputs.noisy_valid = capture.noisy.NumValid();
  return outputs;
}

int RunRender(int argc, char** argv) {
  CLI::App app{
      "Render one catalog model on a floor in front of a wall, ideal and as a "
      "Kinect v1 sees it",
      "workbench render"};
  CatalogFlags catalog_flags;
  AddCatalogFlags(&app, &catalog_flags);
  RenderShowcaseOptions options;
  std::string entry, renderer = "osmesa";
  app.add_option("--entry",
                 entry,
                 "Catalog entry id, e.g. Scopia/chair3 (default: the first classified entry)");
  app.add_option("--out", options.out_dir, "Output directory (created if missing)")->required();
  app.add_option("--distance", options.distance_m, "Camera distance from the model (m)")
      ->capture_default_str();
  app.add_option("--height", options.height_m, "Camera height above the floor (m)")
      ->capture_default_str();
  app.add_option("--pitch", options.pitch_deg, "Camera pitch down (degrees)")
      ->capture_default_str();
  app.add_option("--yaw", options.yaw_deg, "Model rotation about z (degrees)")
      ->capture_default_str();
  app.add_option("--seed", options.seed, "Noise seed")->capture_default_str();
  app.add_option("--renderer", renderer, "osmesa or embree")->capture_default_str();
  bool no_shadow = false, no_range = false, no_incidence = false, no_edges = false,
       no_lateral = false, no_axial = false, no_quantization = false;
  app.add_flag("--no-shadow", no_shadow, "Switch off the projector shadow");
  app.add_flag("--no-range", no_range, "Switch off the 0.5-4.5 m range limits");
  app.add_flag("--no-incidence", no_incidence, "Switch off incidence-angle dropout");
  app.add_flag("--no-edges", no_edges, "Switch off dropout at depth edges");
  app.add_flag("--no-lateral", no_lateral, "Switch off lateral noise");
  app.add_flag("--no-axial", no_axial, "Switch off axial noise");
  app.add_flag("--no-quantization", no_quantization, "Switch off disparity quantisation");
  if (const std::optional<int> exit_code = ParseCommandLine(&app, argc, argv)) return *exit_code;
  ApplyGlobalFlags(catalog_flags);
  options.renderer = ParseRendererKind(renderer);
  options.noise.projector_shadow = !no_shadow;
  options.noise.range_limits = !no_range;
  options.noise.incidence_dropout = !no_incidence;
  options.noise.edge_dropout = !no_edges;
  options.noise.lateral_noise = !no_lateral;
  options.noise.axial_noise = !no_axial;
  options.noise.quantization = !no_quantization;
  const Catalog catalog = OpenCatalog(catalog_flags.spec, MakeOpenOptions(catalog_flags));
  if (entry.empty()) {
    Require(!catalog.Classified().empty(),
            "catalog " + catalog.description() + " has no classified entry; name one with --entry");
    entry = catalog.Classified().front()->id;
  }
  const RenderOutputs outputs = RenderShowcase(catalog.LoadModel(entry), options);
  for (const std::string& file : outputs.files) std::cout << "wrote " << file << "\n";
  std::cout << "valid pixels: ideal " << outputs.ideal_valid << ", noisy " << outputs.noisy_valid
            << "\n";
  return 0;
}

}  // namespace furn
