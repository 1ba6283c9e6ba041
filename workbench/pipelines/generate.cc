#include "workbench/pipelines/generate.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "core/util/error.h"
#include "core/util/parallel.h"
#include "core/util/progress.h"
#include "core/util/random.h"
#include "db/dataset_db.h"
#include "renderers/embree_caster.h"
#include "renderers/kinect_simulator.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/scan_file.h"

namespace furn {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The 8 corners of an object's 3D bounding box in the camera frame.
std::array<Eigen::Vector3d, 8> BoxCornersInCamera(const PlacedObject& object,
                                                  const Eigen::Isometry3d& camera_from_world) {
  const Eigen::Isometry3d camera_from_object = camera_from_world * object.WorldFromObject();
  std::array<Eigen::Vector3d, 8> corners;
  for (int corner = 0; corner < 8; ++corner) {
    corners[corner] =
        camera_from_object * Eigen::Vector3d((corner & 1 ? 0.5 : -0.5) * object.size_m.x(),
                                             (corner & 2 ? 0.5 : -0.5) * object.size_m.y(),
                                             corner & 4 ? object.size_m.z() : 0.0);
  }
  return corners;
}

// Pixels of an object's 3D bounding box in the image (inclusive), or the whole
// image when a corner is behind the camera; empty (u1 < u0) when it is all out of view.
std::array<int, 4> ProjectedRegion(const PlacedObject& object,
                                   const CameraIntrinsics& camera,
                                   const Eigen::Isometry3d& camera_from_world) {
  double u_min = 1e30, v_min = 1e30, u_max = -1e30, v_max = -1e30;
  for (const Eigen::Vector3d& p : BoxCornersInCamera(object, camera_from_world)) {
    if (p.z() < 0.05) return {0, 0, camera.width - 1, camera.height - 1};
    const Eigen::Vector2d pixel = camera.Project(p);
    u_min = std::min(u_min, pixel.x());
    u_max = std::max(u_max, pixel.x());
    v_min = std::min(v_min, pixel.y());
    v_max = std::max(v_max, pixel.y());
  }
  auto clamp = [](double x, int high) { return static_cast<int>(std::clamp(x, -1.0, high + 1.0)); };
  return {clamp(std::floor(u_min) - 1, camera.width - 1),
          clamp(std::floor(v_min) - 1, camera.height - 1),
          clamp(std::ceil(u_max) + 1, camera.width - 1),
          clamp(std::ceil(v_max) + 1, camera.height - 1)};
}

std::string HashFrame(const KinectCapture& capture) {
  ContentHasher hasher;
  for (const DepthFrame* frame : {&capture.ideal, &capture.noisy}) {
    hasher.Update(frame->depth.data(), frame->depth.size() * sizeof(float));
    hasher.Update(frame->instance_ids.data(), frame->instance_ids.size() * sizeof(uint16_t));
  }
  return hasher.HexDigest();
}

// Largest camera-frame depth of the object's 3D bounding box.
float FarDepth(const PlacedObject& object, const Eigen::Isometry3d& camera_from_world) {
  double far = 0;
  for (const Eigen::Vector3d& p : BoxCornersInCamera(object, camera_from_world))
    far = std::max(far, p.z());
  return static_cast<float>(far + 0.01);  // a centimetre of slack for float depth
}

// Visible pixels and boxes of every object from the ideal id image.
void CountVisible(const DepthFrame& ideal, std::vector<FrameObjectRecord>* objects) {
  std::vector<FrameObjectRecord*> by_id(65536, nullptr);  // instance ids are 16-bit
  for (FrameObjectRecord& object : *objects) by_id[object.instance_id] = &object;
  for (int v = 0; v < ideal.height; ++v) {
    for (int u = 0; u < ideal.width; ++u) {
      FrameObjectRecord* object = by_id[ideal.IdAt(u, v)];
      if (object == nullptr) continue;
      std::array<int, 4>& box = object->visible_box;
      if (object->visible_pixels++ == 0) box = {u, v, u, v};
      box = {std::min(box[0], u), std::min(box[1], v), std::max(box[2], u), std::max(box[3], v)};
    }
  }
}

class RoomGenerator {
 public:
  RoomGenerator(const Catalog& catalog, const GenerateOptions& options)
      : catalog_(catalog),
        options_(options),
        composer_catalogs_(ComposerCatalogsOf(catalog, options)) {
    // Rooms are independent, so each worker renders whole rooms with its own
    // renderer: no per-frame hand-offs between threads. OSMesa keeps one
    // context (llvmpipe threads on its own).
    const int slots = options.renderer == RendererKind::kEmbree ? ParallelThreads() : 1;
    RequireEmbreeDevice();  // ground truth casts with Embree whatever the renderer
    for (int slot = 0; slot < slots; ++slot) {
      auto worker = std::make_unique<Worker>();
      worker->renderer = MakeRenderer(options.renderer);
      worker->simulator = std::make_unique<KinectSimulator>(worker->renderer.get(), options.noise);
      workers_.push_back(std::move(worker));
    }
  }

  // Rooms rendered at once by GenerateBatch.
  int Slots() const { return static_cast<int>(workers_.size()); }

  // Composes the rooms and imports their models ahead of time (all cores), so
  // rendering does not wait; Generate then uses these layouts.
  void Prefetch(const std::vector<int64_t>& room_indices, GenerateSummary* summary) {
    auto start = Clock::now();
    std::vector<const RoomLayout*> layouts;
    for (int64_t k : room_indices)
      layouts.push_back(&prefetched_.emplace(k, Compose(k)).first->second);
    summary->compose_s += SecondsSince(start);
    start = Clock::now();
    ImportModels(layouts);
    summary->load_s += SecondsSince(start);
  }

  struct Batch {
    std::vector<RoomRecord> rooms;                    // in the order asked
    std::map<std::string, std::string> model_hashes;  // of every model the rooms use
  };

  // Composes and imports `room_indices`, then renders them Slots() rooms at
  // a time (each room on one thread, so loops inside run serially), with
  // stage times summed over the workers. Runs beside the writing of the
  // previous batch: it touches nothing TakeNewModels reads.
  Batch GenerateBatch(const std::vector<int64_t>& room_indices, GenerateSummary* summary) {
    Prefetch(room_indices, summary);
    Batch batch;
    std::vector<RoomRecord>& rooms = batch.rooms;
    rooms.resize(room_indices.size());
    std::vector<GenerateSummary> times(room_indices.size());
    std::vector<std::map<std::string, std::shared_ptr<const TriangleMesh>>> meshes;
    for (int64_t k : room_indices) meshes.push_back(MeshesOf(prefetched_.at(k)));
    // One loop per worker, each taking the next room not taken yet: a worker
    // never renders two rooms at once, and a single worker (OSMesa) renders
    // them one after another.
    std::atomic<size_t> next_room{0};
    ParallelFor(0, Slots(), [&](int slot) {
      for (size_t r = next_room++; r < room_indices.size(); r = next_room++) {
        rooms[r] = Generate(room_indices[r], meshes[r], workers_[slot].get(), &times[r]);
      }
    });
    for (int64_t k : room_indices) {
      for (const PlacedObject& object : prefetched_.at(k).objects)
        batch.model_hashes[object.model_id] = mesh_cache_.at(object.model_id).content_hash;
      prefetched_.erase(k);
    }
    for (const GenerateSummary& time : times) {
      summary->load_s += time.load_s;
      summary->render_s += time.render_s;
      summary->ground_truth_s += time.ground_truth_s;
      summary->encode_s += time.encode_s;
    }
    return batch;
  }

  // Models of `room` not given out before, for the database (called in room
  // order, so a model is written with the first room that uses it).
  std::vector<ModelRecord> TakeNewModels(const RoomRecord& room, const Batch& batch) {
    std::vector<ModelRecord> models;
    for (const ObjectRecord& object : room.objects) {
      if (!recorded_.insert(object.model_id).second) continue;
      models.push_back(ModelRecord{object.model_id,
                                   object.furniture_class,
                                   batch.model_hashes.at(object.model_id),
                                   Eigen::Vector3d(object.width, object.depth, object.height),
                                   catalog_.Get(object.model_id).evaluation_only});
    }
    std::sort(models.begin(), models.end(), [](const ModelRecord& a, const ModelRecord& b) {
      return a.id < b.id;
    });
    return models;
  }

 private:
  struct Worker {
    std::unique_ptr<DepthRenderer> renderer;
    std::unique_ptr<KinectSimulator> simulator;
  };

  RoomRecord Generate(int64_t room_index,
                      const std::map<std::string, std::shared_ptr<const TriangleMesh>>& meshes,
                      Worker* worker,
                      GenerateSummary* summary) const {
    const uint64_t room_seed = DeriveSeed(options_.seed, static_cast<uint64_t>(room_index));
    const RoomLayout& layout = prefetched_.at(room_index);
    auto start = Clock::now();
    const Scene scene = BuildRoomScene(layout, meshes);
    summary->load_s += SecondsSince(start);

    RoomRecord room;
    room.id = room_index;
    room.seed = room_seed;
    room.split = SplitForSeed(room_seed);
    room.width = layout.width_m;
    room.depth = layout.depth_m;
    room.requested_furniture = layout.requested_furniture;
    room.placed_furniture = layout.placed_furniture;
    for (const PlacedObject& placed : layout.objects)
      room.objects.push_back(ObjectRecordOf(placed));

    ObjectGroundTruth ground_truth(layout, scene);
    for (size_t j = 0; j < layout.world_from_cameras.size(); ++j) {
      room.frames.push_back(MakeFrame(room,
                                      layout,
                                      scene,
                                      &ground_truth,
                                      static_cast<int>(j),
                                      worker->simulator.get(),
                                      summary));
    }
    return room;
  }

  ObjectRecord ObjectRecordOf(const PlacedObject& placed) const {
    ObjectRecord object;
    object.instance_id = placed.instance_id;
    object.model_id = placed.model_id;
    object.furniture_class = placed.furniture_class;
    object.x = placed.x;
    object.y = placed.y;
    object.z = placed.z;
    object.yaw = placed.yaw;
    object.reference_x = placed.x;  // the model origin is the footprint centre
    object.reference_y = placed.y;
    object.width = placed.size_m.x();
    object.depth = placed.size_m.y();
    object.height = placed.size_m.z();
    return object;
  }

  // Imports, in parallel, the models of `layouts` not imported yet.
  void ImportModels(const std::vector<const RoomLayout*>& layouts) {
    std::vector<std::string> missing;
    for (const RoomLayout* layout : layouts) {
      for (const PlacedObject& object : layout->objects) {
        if (mesh_cache_.count(object.model_id) == 0 &&
            std::find(missing.begin(), missing.end(), object.model_id) == missing.end()) {
          missing.push_back(object.model_id);
        }
      }
    }
    if (missing.empty()) return;
    LoadedModels loaded = catalog_.LoadModels(missing, /*show_progress=*/false);
    loaded.RequireAll();  // a model the composer picked must load
    for (CadModel& model : loaded.models) {
      mesh_cache_[model.id] = {std::make_shared<TriangleMesh>(std::move(model.mesh)),
                               model.content_hash};
    }
  }

  RoomLayout Compose(int64_t room_index) const {
    // With leave-models-out folds, room k's targets are fold k % K's models.
    const int fold = options_.model_folds > 0 ? FoldOfRoom(room_index, options_.model_folds) : 0;
    return ComposeRoom(composer_catalogs_[fold],
                       options_.room,
                       DeriveSeed(options_.seed, static_cast<uint64_t>(room_index)));
  }

  // The meshes of `layout`'s models (imported by Prefetch).
  std::map<std::string, std::shared_ptr<const TriangleMesh>> MeshesOf(
      const RoomLayout& layout) const {
    std::map<std::string, std::shared_ptr<const TriangleMesh>> meshes;
    for (const PlacedObject& object : layout.objects)
      meshes[object.model_id] = mesh_cache_.at(object.model_id).mesh;
    return meshes;
  }

  FrameRecord MakeFrame(const RoomRecord& room,
                        const RoomLayout& layout,
                        const Scene& scene,
                        ObjectGroundTruth* ground_truth,
                        int index,
                        KinectSimulator* simulator,
                        GenerateSummary* summary) const {
    const CameraIntrinsics& camera = options_.camera;
    FrameRecord frame;
    frame.frame_index = index;
    frame.id = room.id * options_.room.frames_per_room + index;
    frame.seed = DeriveSeed(room.seed, static_cast<uint64_t>(index) + 1);
    SetIntrinsics(camera, &frame);
    frame.world_from_camera = layout.world_from_cameras[index];

    auto start = Clock::now();
    const KinectCapture& capture =
        simulator->Capture(scene, camera, frame.world_from_camera, frame.seed);
    summary->render_s += SecondsSince(start);

    start = Clock::now();
    frame.objects = ground_truth->Compute(capture.ideal, camera, frame.world_from_camera);
    frame.content_hash = HashFrame(capture);
    summary->ground_truth_s += SecondsSince(start);

    start = Clock::now();
    std::vector<uint8_t>* outputs[4] = {
        &frame.depth_ideal_png, &frame.depth_noisy_png, &frame.ids_png, &frame.ids_noisy_png};
    for (int k = 0; k < 4; ++k) {
      *outputs[k] = k < 2 ? EncodeDepthPng(k == 0 ? capture.ideal : capture.noisy)
                          : EncodeIdPng(k == 2 ? capture.ideal : capture.noisy);
    }
    summary->encode_s += SecondsSince(start);
    return frame;
  }

 private:
  const Catalog& catalog_;
  const GenerateOptions& options_;
  // What rooms are composed from: one, or one per leave-models-out fold.
  static std::vector<ComposerCatalog> ComposerCatalogsOf(const Catalog& catalog,
                                                         const GenerateOptions& options) {
    ComposerCatalog all = ComposerCatalog::From(catalog, options.room);
    if (!options.excluded_models.empty()) {
      std::set<std::string> kept;
      for (const ComposerCatalog::Item& item : all.furniture) {
        if (!options.excluded_models.count(item.id)) kept.insert(item.id);
      }
      all = all.WithFurnitureFrom(kept);
    }
    if (options.model_folds == 0) return {all};
    const ModelFolds folds = AssignModelFolds(catalog, options.model_folds, options.fold_seed);
    std::vector<ComposerCatalog> per_fold;
    for (int k = 0; k < folds.count; ++k)
      per_fold.push_back(all.WithFurnitureFrom(folds.ModelsOf(k)));
    return per_fold;
  }

  std::vector<ComposerCatalog> composer_catalogs_;
  std::vector<std::unique_ptr<Worker>> workers_;
  struct CachedModel {
    std::shared_ptr<const TriangleMesh> mesh;
    std::string content_hash;
  };
  std::map<std::string, CachedModel> mesh_cache_;
  std::set<std::string> recorded_;            // models given out by TakeNewModels() already
  std::map<int64_t, RoomLayout> prefetched_;  // composed by Prefetch, waiting for Generate
};

}  // namespace

ObjectGroundTruth::ObjectGroundTruth(const RoomLayout& layout, const Scene& scene)
    : layout_(layout) {
  const size_t structure =
      scene.objects.size() - layout.objects.size();  // floor and walls come first
  for (size_t k = 0; k < layout.objects.size(); ++k) {
    Scene alone;
    alone.objects.push_back(scene.objects[structure + k]);
    alone_.push_back(std::move(alone));
    casters_.push_back(std::make_unique<EmbreeCaster>());
  }
}

ObjectGroundTruth::~ObjectGroundTruth() = default;

std::vector<FrameObjectRecord> ObjectGroundTruth::Compute(
    const DepthFrame& ideal,
    const CameraIntrinsics& camera,
    const Eigen::Isometry3d& world_from_camera) {
  std::vector<FrameObjectRecord> objects;
  const Eigen::Isometry3d camera_from_world = world_from_camera.inverse();
  // One object per task: their ray-casting scenes are independent.
  objects.resize(layout_.objects.size());
  ParallelFor(0, static_cast<int>(layout_.objects.size()), [&](int k) {
    FrameObjectRecord& object = objects[k];
    object.instance_id = layout_.objects[k].instance_id;
    const std::array<int, 4> region =
        ProjectedRegion(layout_.objects[k], camera, camera_from_world);
    const EmbreeCaster::Coverage amodal = casters_[k]->CoverageIn(
        alone_[k],
        camera,
        world_from_camera,
        region,
        EmbreeCaster::KnownHits{&ideal.instance_ids,
                                &ideal.depth,
                                static_cast<uint16_t>(object.instance_id),
                                FarDepth(layout_.objects[k], camera_from_world)});
    object.amodal_pixels = amodal.pixels;
    object.amodal_box = amodal.box;
    object.in_frustum = amodal.pixels > 0;
  });
  CountVisible(ideal, &objects);
  for (FrameObjectRecord& object : objects) {
    object.visibility =
        object.amodal_pixels > 0
            ? std::min(1.0, static_cast<double>(object.visible_pixels) / object.amodal_pixels)
            : 0.0;
  }
  return objects;
}

void GenerateOptions::Check() const {
  Require(rooms >= 1 && rooms <= 1000000,
          "rooms " + std::to_string(rooms) + " must be in 1..1000000");
  Require(shard_count >= 1 && shard_index >= 0 && shard_index < shard_count,
          "shard " + std::to_string(shard_index) + "/" + std::to_string(shard_count) +
              " must satisfy 0 <= i < N");
  Require(model_folds == 0 || (model_folds >= 2 && model_folds <= 20),
          "model folds " + std::to_string(model_folds) + " must be 0 (off) or in 2..20");
  Require(model_folds == 0 || rooms >= model_folds,
          "rooms " + std::to_string(rooms) + " must be at least the " +
              std::to_string(model_folds) + " model folds (a fold's rooms are k % folds)");
  room.Check();
  noise.Check();
  camera.Check();
}

std::string GenerateOptions::ContentJson() const {
  nlohmann::ordered_json json{
      {"catalog", catalog_spec},
      {"rooms", rooms},
      {"seed", seed},
      {"renderer", renderer == RendererKind::kEmbree ? "embree" : "osmesa"},
      {"camera", {camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy}},
      {"room",
       {{"min_side_m", room.min_side_m},
        {"max_side_m", room.max_side_m},
        {"min_furniture", room.min_furniture},
        {"max_furniture", room.max_furniture},
        {"min_clutter", room.min_clutter},
        {"max_clutter", room.max_clutter},
        {"clearance_m", room.clearance_m},
        {"wall_height_m", room.wall_height_m},
        {"frames_per_room", room.frames_per_room},
        {"min_camera_height_m", room.min_camera_height_m},
        {"max_camera_height_m", room.max_camera_height_m},
        {"min_pitch_deg", room.min_pitch_deg},
        {"max_pitch_deg", room.max_pitch_deg},
        {"include_evaluation_only", room.include_evaluation_only}}},
      {"noise",
       {{"baseline_m", noise.baseline_m},
        {"projector_shadow", noise.projector_shadow},
        {"range_limits", noise.range_limits},
        {"min_range_m", noise.min_range_m},
        {"max_range_m", noise.max_range_m},
        {"incidence_dropout", noise.incidence_dropout},
        {"max_incidence_deg", noise.max_incidence_deg},
        {"edge_dropout", noise.edge_dropout},
        {"edge_jump_m", noise.edge_jump_m},
        {"edge_dropout_probability", noise.edge_dropout_probability},
        {"lateral_noise", noise.lateral_noise},
        {"axial_noise", noise.axial_noise},
        {"quantization", noise.quantization},
        {"disparity_step_px", noise.disparity_step_px}}}};
  // Only when on, so datasets made before the option keep their content (and resume).
  if (model_folds > 0) json["model_folds"] = {{"folds", model_folds}, {"seed", fold_seed}};
  if (!clutter_catalog_specs.empty()) json["clutter_catalogs"] = clutter_catalog_specs;
  if (!excluded_models.empty()) json["excluded_models"] = excluded_models;
  if (room.size_jitter > 0) json["room"]["size_jitter"] = room.size_jitter;
  if (room.max_clutter_side_m != RoomOptions{}.max_clutter_side_m)
    json["room"]["max_clutter_side_m"] = room.max_clutter_side_m;
  if (room.surface_clutter > 0) json["room"]["surface_clutter"] = room.surface_clutter;
  if (room.include_vote_net_only) json["room"]["include_vote_net_only"] = true;
  // The fitted sensor's fields (issue 69) only when set, likewise.
  if (noise.noise_scale != 1.0) json["noise"]["noise_scale"] = noise.noise_scale;
  if (noise.correlated_share > 0) {
    json["noise"]["correlated_share"] = noise.correlated_share;
    json["noise"]["correlation_radius_px"] = noise.correlation_radius_px;
  }
  return json.dump();
}

std::pair<int, int> ParseShard(const std::string& text) {
  const size_t slash = text.find('/');
  try {
    size_t used_i = 0, used_n = 0;
    const int i = std::stoi(text.substr(0, slash), &used_i);
    const int n = slash == std::string::npos ? 0 : std::stoi(text.substr(slash + 1), &used_n);
    if (slash != std::string::npos && used_i == slash && used_n == text.size() - slash - 1 &&
        n >= 1 && i >= 0 && i < n) {
      return {i, n};
    }
  } catch (const std::exception&) {
  }
  throw InputError("shard '" + text + "' must be i/N with 0 <= i < N, e.g. 0/4");
}

namespace {

// Writes one generated room (and the models it uses first) in its own
// transaction.
void WriteGeneratedRoom(const RoomRecord& room,
                        const RoomGenerator::Batch& batch,
                        RoomGenerator* generator,
                        DatasetDb* dataset,
                        GenerateSummary* summary,
                        Progress* progress) {
  const auto insert_start = Clock::now();
  dataset->WriteModels(generator->TakeNewModels(room, batch));
  dataset->WriteRoom(room, [&] {
    // Test hook: die inside the room's transaction, as a killed run would.
    if (const char* crash = std::getenv("FURN_TEST_CRASH_IN_ROOM");
        crash && std::atoll(crash) == room.id) {
      std::_Exit(3);
    }
  });
  summary->insert_s += SecondsSince(insert_start);
  ++summary->rooms_written;
  summary->frames_written += static_cast<int>(room.frames.size());
  summary->rooms_short += room.placed_furniture < room.requested_furniture;
  progress->AddSecondary(room.frames.size(), "frames");
  progress->Advance();
}

}  // namespace

GenerateSummary GenerateDataset(const Catalog& catalog,
                                const GenerateOptions& options,
                                const std::string& db_path) {
  options.Check();
  const auto start = Clock::now();
  // Renderers first: one that cannot start (no Embree device for this CPU or
  // FURN_EMBREE_CONFIG, no OSMesa context) fails before a dataset file exists.
  RoomGenerator generator(catalog, options);
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadWrite);
  const std::string content = options.ContentJson();
  if (const auto existing = dataset.GenerationOptions()) {
    if (*existing != content) {
      std::string fields;
      for (const auto& change :
           nlohmann::json::diff(nlohmann::json::parse(*existing), nlohmann::json::parse(content))) {
        fields += (fields.empty() ? "" : ", ") + change["path"].get<std::string>();
      }
      throw InputError(db_path + ": was generated with other options (" + fields +
                       " differ); use a new file, or the same options to resume");
    }
  } else {
    dataset.SetGenerationOptions(content);
  }
  GenerateSummary summary;
  std::vector<int64_t> todo;
  for (int64_t k = options.shard_index; k < options.rooms; k += options.shard_count) {
    ++summary.rooms_in_shard;
    if (dataset.HasRoom(k)) {
      ++summary.rooms_already_present;
    } else {
      todo.push_back(k);
    }
  }
  summary.workers = generator.Slots();
  Progress progress("generate", todo.size(), "rooms");
  // Rooms go in batches: composed and imported on all cores, rendered a room
  // per core, then written in order, one transaction each, while the next
  // batch renders (so the cores do not wait for SQLite, nor for the slowest
  // room of a batch for long).
  const size_t batch_rooms = 6 * static_cast<size_t>(generator.Slots());
  auto start_batch = [&](size_t first) {
    const std::vector<int64_t> rooms(todo.begin() + first,
                                     todo.begin() + std::min(todo.size(), first + batch_rooms));
    return std::async(std::launch::async, [&generator, &summary, rooms] {
      return generator.GenerateBatch(rooms, &summary);
    });
  };
  std::future<RoomGenerator::Batch> next;
  if (!todo.empty()) next = start_batch(0);
  for (size_t first = 0; first < todo.size(); first += batch_rooms) {
    const RoomGenerator::Batch batch = next.get();
    if (first + batch_rooms < todo.size()) next = start_batch(first + batch_rooms);
    for (const RoomRecord& room : batch.rooms)
      WriteGeneratedRoom(room, batch, &generator, &dataset, &summary, &progress);
  }
  progress.Finish();
  summary.seconds = SecondsSince(start);
  return summary;
}

Catalog OpenGenerationCatalog(const std::string& spec,
                              const std::vector<std::string>& clutter_specs,
                              const CatalogOpenOptions& open_options,
                              const RoomOptions& room,
                              bool quiet) {
  Catalog catalog = OpenCatalog(spec, open_options);
  for (const std::string& clutter : clutter_specs) {
    const int added = catalog.AddClutter(OpenCatalog(clutter, open_options));
    Require(added > 0,
            "--clutter-catalog " + clutter +
                ": no unclassified entry to add (every entry is classified, a door or window, "
                "or already in the catalog)");
    if (!quiet) std::fprintf(stderr, "clutter: %d entries of %s added\n", added, clutter.c_str());
  }
  for (const std::string& warning : catalog.warnings())
    std::fprintf(stderr, "warning: %s\n", warning.c_str());
  if (room.max_clutter > 0 && ComposerCatalog::From(catalog, room).clutter.empty()) {
    std::fprintf(stderr,
                 "warning: catalog %s offers no clutter (every entry is classified, or the rest "
                 "are not 0.1-1.6 m across and 0.05-2 m tall): rooms hold targets only; list "
                 "distractors as \"class\": \"clutter\" entries of a version-2 class map, or add "
                 "--clutter-catalog default\n",
                 catalog.description().c_str());
  }
  return catalog;
}

}  // namespace furn
