#include "workbench/pipelines/train.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include "core/codebook/hypothesis_scorer.h"
#include "core/util/error.h"
#include "core/util/progress.h"
#include "core/util/random.h"
#include "core/util/text.h"
#include "renderers/embree_caster.h"
#include "renderers/kinect_noise.h"
#include "reports/evaluation.h"                 // kOwnOperatingPointObjects
#include "workbench/pipelines/dataset_tools.h"  // CheckMergeable
#include "workbench/pipelines/vote_net_checkpoint.h"

namespace furn {

TriangleMesh ScaledMesh(const TriangleMesh& mesh, const Eigen::Vector3f& scale) {
  TriangleMesh scaled = mesh;
  for (Eigen::Vector3f& v : scaled.vertices) v = v.cwiseProduct(scale);
  return scaled;
}

std::vector<TrainingView> ScanModel(const CadModel& model,
                                    int model_index,
                                    FurnitureClass furniture_class,
                                    const ScanOptions& options) {
  options.Check();
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  EmbreeCaster caster;
  KinectNoiseModel noise{KinectNoiseOptions{}};
  DepthFrame ideal, noisy;
  std::vector<TrainingView> views;
  for (int variant = 0; variant <= options.scale_variants; ++variant) {
    Eigen::Vector3f scale = Eigen::Vector3f::Ones();
    if (variant > 0) {
      Rng random(DeriveSeed(DeriveSeed(options.seed ^ 0x5ca1e, static_cast<uint64_t>(model_index)),
                            static_cast<uint64_t>(variant)));
      for (int axis = 0; axis < 3; ++axis) {
        scale[axis] =
            static_cast<float>(random.Uniform(1 - options.scale_jitter, 1 + options.scale_jitter));
      }
    }
    Scene scene;
    scene.objects.push_back({std::make_shared<TriangleMesh>(ScaledMesh(model.mesh, scale)),
                             Eigen::Isometry3d::Identity(),
                             kFirstObjectId});
    const double centre_height = BoundingBox(model.mesh).Size().z() * scale.z() / 2;
    for (size_t ring = 0; ring < options.heights_m.size(); ++ring) {
      const double t = options.heights_m.size() > 1
                           ? static_cast<double>(ring) / (options.heights_m.size() - 1)
                           : 0;
      const double distance =
          options.min_distance_m + t * (options.max_distance_m - options.min_distance_m);
      for (int a = 0; a < options.azimuths; ++a) {
        // Half a step between rings, so the rings see different sides.
        const double azimuth = 2 * M_PI * (a + 0.5 * ring) / options.azimuths;
        const Eigen::Vector3d eye(
            distance * std::sin(azimuth), -distance * std::cos(azimuth), options.heights_m[ring]);
        const Eigen::Isometry3d world_from_camera =
            LookAlong(eye, Eigen::Vector3d(0, 0, centre_height) - eye);
        caster.RenderInto(scene, camera, world_from_camera, &ideal);
        const uint64_t seed =
            DeriveSeed(DeriveSeed(options.seed, static_cast<uint64_t>(model_index)),
                       variant * 1000000 + ring * 1000 + static_cast<uint64_t>(a));
        noise.Apply(ideal, camera, seed, &noisy);
        TrainingView view;
        view.sensor_origin = eye.cast<float>();
        view.model_index = model_index;
        view.furniture_class = furniture_class;
        view.augmented = variant > 0;
        for (int v = 0; v < camera.height; ++v) {
          for (int u = 0; u < camera.width; ++u) {
            const float z = noisy.DepthAt(u, v);
            if (z <= 0) continue;
            view.points.push_back(
                (world_from_camera * (z * camera.RayThroughPixel(u, v)).cast<double>())
                    .cast<float>());
          }
        }
        if (!view.points.empty()) views.push_back(std::move(view));
      }
    }
  }
  return views;
}

std::string LastWeightsModelPath(const std::string& model_path) {
  std::filesystem::path path(model_path);
  if (path.extension() == ".fcm") path.replace_extension();
  return path.string() + ".last.fcm";
}

TrainSummary TrainFromCatalog(const Catalog& catalog,
                              const ScanOptions& scan,
                              const TrainerOptions& trainer,
                              const std::string& out_path,
                              const std::set<std::string>& held_out,
                              const std::string& scorer,
                              const VoteNetTrainingOptions* vote_net) {
  scan.Check();
  trainer.Check();
  if (vote_net != nullptr) vote_net->Check();
  // The training rooms' shards, checked before anything is trained.
  if (vote_net != nullptr && !vote_net->room_shards.empty())
    CheckMergeable(vote_net->room_shards,
                   "; rerun the tasks of 'train --shards' that did not finish");
  std::vector<std::string> ids;
  std::vector<FurnitureClass> classes;
  for (const CatalogEntry* entry : catalog.Classified()) {
    if (entry->evaluation_only || entry->vote_net_only || held_out.count(entry->id)) continue;
    ids.push_back(entry->id);
    classes.push_back(*entry->furniture_class);
  }
  Require(!ids.empty(),
          "catalog " + catalog.description() + " has no class-mapped entries to train on");
  TrainSummary summary;
  auto start = std::chrono::steady_clock::now();
  LoadedModels loaded = catalog.LoadModels(ids);
  loaded.RequireAll();
  std::vector<TrainingView> views;
  Progress progress("scan", loaded.models.size(), "models");
  for (size_t i = 0; i < loaded.models.size(); ++i) {
    std::vector<TrainingView> model_views =
        ScanModel(loaded.models[i], static_cast<int>(i), classes[i], scan);
    views.insert(views.end(),
                 std::make_move_iterator(model_views.begin()),
                 std::make_move_iterator(model_views.end()));
    progress.Advance();
  }
  progress.Finish();
  summary.scan_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  start = std::chrono::steady_clock::now();
  TrainedModel model = TrainModel(views, ids, classes, trainer, &summary.stages);
  model.scorer = scorer;
  for (const CadModel& cad : loaded.models)
    model.render_meshes.push_back(SimplifyMesh(cad.mesh, kRenderMeshCellM));
  if (vote_net != nullptr) {
    VoteNetTrainingOptions options = *vote_net;
    if (options.curve_png.empty()) options.curve_png = out_path + ".training.png";
    // A killed training resumes after its last epoch when rerun.
    if (options.checkpoint_path.empty()) options.checkpoint_path = out_path + ".checkpoint";
    model.vote_net = TrainVoteNet(
        catalog, held_out, options, out_path + ".rooms.db", &summary.vote_net_training);
    summary.vote_net = true;
    model.operating_point = summary.vote_net_training.operating_point;
    model.vote_net_input = VoteNetInputOf(options);
  }
  SaveTrainedModel(model, out_path);
  if (vote_net != nullptr && !summary.vote_net_training.last_weights.empty()) {
    TrainedModel last = model;
    last.vote_net = summary.vote_net_training.last_weights;
    last.operating_point = summary.vote_net_training.last_operating_point;
    SaveTrainedModel(last, LastWeightsModelPath(out_path));
  }
  if (vote_net != nullptr) {  // the model holds what they kept
    VoteNetTrainingOptions options = *vote_net;
    if (options.checkpoint_path.empty()) options.checkpoint_path = out_path + ".checkpoint";
    RemoveCheckpoints(options);
  }
  summary.train_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.models = static_cast<int>(ids.size());
  summary.views = static_cast<int>(views.size());
  summary.segments = model.training_segments;
  summary.used_words = model.vocabulary.NumUsedWords();
  return summary;
}

VoteNetInput VoteNetInputOf(const VoteNetTrainingOptions& options) {
  VoteNetInput input;
  input.recorded = true;
  input.fused_share = options.fused_share;
  input.pose_noise_m = options.fused_pose_noise_m;
  input.pose_noise_deg = options.fused_pose_noise_deg;
  input.planar = options.fused_planar_noise;
  return input;
}

}  // namespace furn
