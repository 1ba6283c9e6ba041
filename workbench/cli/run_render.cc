#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "workbench/cli/cli_common.h"
#include "workbench/cli/commands.h"
#include "workbench/pipelines/render_showcase.h"

namespace furn {

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
