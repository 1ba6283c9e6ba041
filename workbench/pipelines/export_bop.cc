#include "workbench/pipelines/export_bop.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "core/geometry/mesh_symmetry.h"
#include "core/geometry/scene.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/parallel.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "renderers/embree_caster.h"
#include "workbench/formats/depth_png.h"

namespace furn {
namespace {

using ordered_json = nlohmann::ordered_json;

std::string Pad(int64_t value) {
  char text[24];
  std::snprintf(text, sizeof(text), "%06lld", static_cast<long long>(value));
  return text;
}

ordered_json Rows(const Eigen::Matrix3d& m) {
  return {m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)};
}

ordered_json Millimetres(const Eigen::Vector3d& metres) {
  const Eigen::Vector3d mm = metres * 1000.0;
  return {mm.x(), mm.y(), mm.z()};
}

// The largest distance between two vertices. Exact up to 2,000 vertices;
// above, over the extreme vertices along 1,000 directions (the diameter's
// ends are extreme along its own direction; missing it by a few degrees
// shortens it by under 0.1 %).
double Diameter(const std::vector<Eigen::Vector3f>& vertices) {
  std::vector<Eigen::Vector3d> candidates;
  if (vertices.size() <= 2000) {
    for (const Eigen::Vector3f& v : vertices) candidates.push_back(v.cast<double>());
  } else {
    std::set<size_t> extreme;
    constexpr int kDirections = 1000;
    const double golden = M_PI * (3 - std::sqrt(5.0));
    for (int k = 0; k < kDirections; ++k) {  // a Fibonacci sphere
      const double z = 1 - 2 * (k + 0.5) / kDirections, r = std::sqrt(1 - z * z);
      const Eigen::Vector3f direction(static_cast<float>(r * std::cos(golden * k)),
                                      static_cast<float>(r * std::sin(golden * k)),
                                      static_cast<float>(z));
      size_t low = 0, high = 0;
      for (size_t i = 1; i < vertices.size(); ++i) {
        const float d = direction.dot(vertices[i]);
        if (d < direction.dot(vertices[low])) low = i;
        if (d > direction.dot(vertices[high])) high = i;
      }
      extreme.insert(low);
      extreme.insert(high);
    }
    for (size_t i : extreme) candidates.push_back(vertices[i].cast<double>());
  }
  double best = 0;
  for (size_t i = 0; i < candidates.size(); ++i) {
    for (size_t j = i + 1; j < candidates.size(); ++j)
      best = std::max(best, (candidates[i] - candidates[j]).squaredNorm());
  }
  return std::sqrt(best);
}

// ASCII PLY in millimetres, centred: what the toolkit's load_ply reads.
void WriteModelPly(const TriangleMesh& mesh,
                   const Eigen::Vector3f& centre,
                   const std::string& path) {
  std::ostringstream out;
  out.precision(9);
  out << "ply\nformat ascii 1.0\ncomment furnidet export, millimetres, centred on the bounding "
         "box\nelement vertex "
      << mesh.vertices.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
      << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const Eigen::Vector3f& v : mesh.vertices) {
    const Eigen::Vector3f mm = (v - centre) * 1000.0f;
    out << mm.x() << ' ' << mm.y() << ' ' << mm.z() << '\n';
  }
  for (const Eigen::Vector3i& t : mesh.triangles)
    out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  WriteFileAtomically(path, out.str());
}

struct ExportedModel {
  int obj_id = 0;
  std::shared_ptr<const TriangleMesh> mesh;
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();  // of the bounding box, model frame (m)
  std::string model_id, furniture_class;
};

// The bounding box of the pixels set in `mask` (row-major, `width` wide) as
// BOP writes it: x, y, width, height; -1s when none.
ordered_json BoxOf(const std::vector<uint8_t>& mask, int width) {
  int u0 = width, v0 = std::numeric_limits<int>::max(), u1 = -1, v1 = -1;
  for (size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    const int u = static_cast<int>(i % width), v = static_cast<int>(i / width);
    u0 = std::min(u0, u);
    u1 = std::max(u1, u);
    v0 = std::min(v0, v);
    v1 = std::max(v1, v);
  }
  if (u1 < 0) return {-1, -1, -1, -1};
  return {u0, v0, u1 - u0 + 1, v1 - v0 + 1};
}

}  // namespace

namespace {

// The catalog the dataset was generated from, with its clutter catalogs.
Catalog CatalogOfDataset(DatasetDb& dataset,
                         const std::string& db_path,
                         const CatalogOpenOptions& open_options) {
  const std::optional<std::string> generation = dataset.GenerationOptions();
  Require(generation.has_value(),
          db_path +
              ": BOP export needs the CAD models, and this dataset was not generated from a "
              "catalog (a real set?); export it as png or pcd");
  const nlohmann::json generated = nlohmann::json::parse(*generation, nullptr, false);
  Require(
      generated.is_object() && generated.contains("catalog") && generated["catalog"].is_string(),
      db_path + ": its generation options name no catalog");
  Catalog catalog = OpenCatalog(generated["catalog"].get<std::string>(), open_options);
  if (generated.contains("clutter_catalogs") && generated["clutter_catalogs"].is_array()) {
    for (const nlohmann::json& spec : generated["clutter_catalogs"]) {
      if (spec.is_string()) catalog.AddClutter(OpenCatalog(spec.get<std::string>(), open_options));
    }
  }
  return catalog;
}

// BOP's symmetries of a model (its frame centred on the bounding box, z up):
// a continuous one about z, or the discrete turns about z as 4x4 matrices
// (row-major, translation in mm: 0, the axis passes through the centre).
void AddSymmetries(const MeshSymmetry& symmetry, ordered_json* info) {
  if (symmetry.continuous) {
    (*info)["symmetries_continuous"] = {{{"axis", {0, 0, 1}}, {"offset", {0, 0, 0}}}};
    return;
  }
  if (symmetry.order < 2) return;
  ordered_json turns = ordered_json::array();
  for (int k = 1; k < symmetry.order; ++k) {
    const double angle = 2 * M_PI * k / symmetry.order;
    // Exact zeros and ones at quarter turns (cos 90° is 6e-17 in doubles).
    const double c = std::round(std::cos(angle) * 1e12) / 1e12;
    const double s = std::round(std::sin(angle) * 1e12) / 1e12;
    turns.push_back({c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
  }
  (*info)["symmetries_discrete"] = turns;
}

// BOP19's targets: instances at least this visible (visib_fract).
constexpr double kBopTargetVisibility = 0.1;

// Models: obj_id in the dataset's model order, meshes as generated, written
// in mm centred on their boxes with models_info.json.
std::map<std::string, ExportedModel> ExportModels(DatasetDb& dataset,
                                                  const Catalog& catalog,
                                                  const std::filesystem::path& root,
                                                  const std::string& db_path) {
  std::filesystem::create_directories(root / "models");
  const std::vector<ModelRecord> records = dataset.ReadModels();
  std::vector<std::string> ids;
  for (const ModelRecord& record : records) ids.push_back(record.id);
  LoadedModels loaded = catalog.LoadModels(ids, /*show_progress=*/false);
  loaded.RequireAll();
  std::map<std::string, ExportedModel> models;
  ordered_json models_info = ordered_json::object(), models_extra = ordered_json::object();
  for (size_t k = 0; k < records.size(); ++k) {
    const ModelRecord& record = records[k];
    CadModel& cad = loaded.models[k];
    Require(cad.content_hash == record.content_hash,
            db_path + ": model " + record.id + " in catalog " + catalog.description() +
                " is not the mesh the dataset was generated with (content hash " +
                cad.content_hash + ", recorded " + record.content_hash + ")");
    ExportedModel& model = models[record.id];
    model.obj_id = static_cast<int>(k) + 1;
    const Box3 box = BoundingBox(cad.mesh);
    model.centre = box.Center();
    model.model_id = record.id;
    model.furniture_class = record.furniture_class ? ClassName(*record.furniture_class) : "";
    WriteModelPly(
        cad.mesh, model.centre, (root / "models" / ("obj_" + Pad(model.obj_id) + ".ply")).string());
    const Eigen::Vector3f low = (box.min - model.centre) * 1000.0f, size = box.Size() * 1000.0f;
    ordered_json& info = models_info[std::to_string(model.obj_id)];
    info = {{"diameter", 1000.0 * Diameter(cad.mesh.vertices)},
            {"min_x", low.x()},
            {"min_y", low.y()},
            {"min_z", low.z()},
            {"size_x", size.x()},
            {"size_y", size.y()},
            {"size_z", size.z()}};
    AddSymmetries(FindVerticalSymmetry(cad.mesh, model.centre), &info);
    models_extra[std::to_string(model.obj_id)] = {{"model_id", record.id},
                                                  {"class", model.furniture_class}};
    model.mesh = std::make_shared<TriangleMesh>(std::move(cad.mesh));
  }
  WriteFileAtomically(
      (root / "models" / "models_info.json").string(),
      models_info.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  WriteFileAtomically(
      (root / "models" / "models_furnidet.json").string(),
      models_extra.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  return models;
}

void WriteCameraJson(const FrameRecord& frame, const std::filesystem::path& root) {
  WriteFileAtomically((root / "camera.json").string(),
                      ordered_json{{"cx", frame.cx},
                                   {"cy", frame.cy},
                                   {"depth_scale", 1.0},
                                   {"fx", frame.fx},
                                   {"fy", frame.fy},
                                   {"height", frame.height},
                                   {"width", frame.width}}
                              .dump(1, ' ', false, nlohmann::json::error_handler_t::replace) +
                          "\n");
}

// One room of the export: a scene per object (the object alone, for its
// amodal mask) with its own caster, and the scene's JSON files.
class BopRoomWriter {
 public:
  // `targets`: where a test room's frames add their BOP19 test targets
  // (nullptr for other splits).
  BopRoomWriter(const RoomRecord& room,
                const std::map<std::string, ExportedModel>& models,
                const std::filesystem::path& scene_dir,
                ordered_json* targets)
      : models_(models), scene_dir_(scene_dir), scene_id_(room.id), targets_(targets) {
    for (const ObjectRecord& object : room.objects) {
      objects_[object.instance_id] = &object;
      const ExportedModel& model = models.at(object.model_id);
      Scene scene;
      scene.objects.push_back(
          {model.mesh, PoseXYZYaw(object.x, object.y, object.z, object.yaw), kFirstObjectId});
      alone_[object.instance_id] = std::move(scene);
      casters_[object.instance_id] = std::make_unique<EmbreeCaster>();
    }
    for (const char* sub : {"depth", "mask", "mask_visib", "depth_ideal", "mask_ids"})
      std::filesystem::create_directories(scene_dir / sub);
  }

  void AddFrame(const FrameRecord& frame, const std::string& db_path) {
    const std::string where = db_path + " frame " + std::to_string(frame.id);
    DepthFrame ids = DecodeDepthPng(frame.depth_ideal_png, where);
    DecodeIdPng(frame.ids_png, where, &ids);
    const DepthFrame noisy = DecodeDepthPng(frame.depth_noisy_png, where);
    const std::string image = Pad(frame.frame_index);
    WriteFileAtomically((scene_dir_ / "depth" / (image + ".png")).string(),
                        std::string(frame.depth_noisy_png.begin(), frame.depth_noisy_png.end()));
    WriteFileAtomically((scene_dir_ / "depth_ideal" / (image + ".png")).string(),
                        std::string(frame.depth_ideal_png.begin(), frame.depth_ideal_png.end()));
    WriteFileAtomically((scene_dir_ / "mask_ids" / (image + ".png")).string(),
                        std::string(frame.ids_png.begin(), frame.ids_png.end()));
    const Eigen::Isometry3d camera_from_world = frame.world_from_camera.inverse();
    const std::string key = std::to_string(frame.frame_index);
    scene_camera_[key] = {{"cam_K", {frame.fx, 0, frame.cx, 0, frame.fy, frame.cy, 0, 0, 1}},
                          {"depth_scale", 1.0},
                          {"cam_R_w2c", Rows(camera_from_world.linear())},
                          {"cam_t_w2c", Millimetres(camera_from_world.translation())}};
    // Every object's masks and counts, objects in parallel.
    const size_t n = frame.objects.size();
    std::vector<ordered_json> gt(n), info(n), extra(n);
    ParallelFor(0, static_cast<int>(n), [&](int k) {
      ExportObject(frame, ids, noisy, image, k, &gt[k], &info[k], &extra[k]);
    });
    if (targets_ != nullptr) AddTargets(frame.frame_index, gt, info, extra);
    scene_gt_[key] = gt;
    scene_gt_info_[key] = info;
    scene_extra_[key] = extra;
  }

  void Finish() const {
    WriteFileAtomically(
        (scene_dir_ / "scene_camera.json").string(),
        scene_camera_.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
    WriteFileAtomically(
        (scene_dir_ / "scene_gt.json").string(),
        scene_gt_.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
    WriteFileAtomically(
        (scene_dir_ / "scene_gt_info.json").string(),
        scene_gt_info_.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
    WriteFileAtomically(
        (scene_dir_ / "scene_gt_furnidet.json").string(),
        scene_extra_.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  }

 private:
  // Object k of the frame: its amodal and visible masks, pose and counts.
  void ExportObject(const FrameRecord& frame,
                    const DepthFrame& ids,
                    const DepthFrame& noisy,
                    const std::string& image,
                    int k,
                    ordered_json* gt,
                    ordered_json* info,
                    ordered_json* extra) {
    const FrameObjectRecord& seen = frame.objects[k];
    const ObjectRecord& object = *objects_.at(seen.instance_id);
    const ExportedModel& model = models_.at(object.model_id);
    const CameraIntrinsics camera{
        frame.width, frame.height, frame.fx, frame.fy, frame.cx, frame.cy};
    DepthFrame rendered;
    casters_.at(seen.instance_id)
        ->RenderInto(alone_.at(seen.instance_id), camera, frame.world_from_camera, &rendered);
    const size_t pixels = static_cast<size_t>(frame.width) * frame.height;
    std::vector<uint8_t> mask(pixels, 0), visible(pixels, 0);
    int64_t all = 0, valid = 0, visib = 0;
    for (size_t i = 0; i < pixels; ++i) {
      if (rendered.instance_ids[i] == kFirstObjectId) {
        mask[i] = 255;
        ++all;
        valid += noisy.depth[i] > 0;
      }
      if (ids.instance_ids[i] == seen.instance_id) {
        visible[i] = 255;
        ++visib;
      }
    }
    const std::string name = image + "_" + Pad(k) + ".png";
    WriteMaskPng(mask, frame.width, frame.height, (scene_dir_ / "mask" / name).string());
    WriteMaskPng(visible, frame.width, frame.height, (scene_dir_ / "mask_visib" / name).string());
    // BOP's model frame is centred on the bounding box.
    const Eigen::Isometry3d camera_from_model =
        frame.world_from_camera.inverse() * PoseXYZYaw(object.x, object.y, object.z, object.yaw) *
        Eigen::Translation3d(model.centre.cast<double>());
    *gt = {{"cam_R_m2c", Rows(camera_from_model.linear())},
           {"cam_t_m2c", Millimetres(camera_from_model.translation())},
           {"obj_id", model.obj_id}};
    *info = {{"bbox_obj", visib > 0 ? BoxOf(mask, frame.width) : ordered_json{-1, -1, -1, -1}},
             {"bbox_visib", BoxOf(visible, frame.width)},
             {"px_count_all", all},
             {"px_count_valid", valid},
             {"px_count_visib", visib},
             {"visib_fract", all > 0 ? static_cast<double>(visib) / all : 0.0}};
    *extra = {{"instance_id", seen.instance_id},
              {"model_id", object.model_id},
              {"class", object.furniture_class ? ClassName(*object.furniture_class) : ""}};
  }

  // The image's targets as BOP19 lists them (test_targets_bop19.json): per
  // object model, the furniture instances (a detection class; clutter is no
  // target) at least 10 % visible.
  void AddTargets(int image,
                  const std::vector<ordered_json>& gt,
                  const std::vector<ordered_json>& info,
                  const std::vector<ordered_json>& extra) {
    std::map<int, int> instances;  // obj_id -> count
    for (size_t k = 0; k < gt.size(); ++k) {
      if (extra[k]["class"].get<std::string>().empty()) continue;
      if (info[k]["visib_fract"].get<double>() < kBopTargetVisibility) continue;
      ++instances[gt[k]["obj_id"].get<int>()];
    }
    for (const auto& [obj_id, count] : instances) {
      targets_->push_back(
          {{"im_id", image}, {"inst_count", count}, {"obj_id", obj_id}, {"scene_id", scene_id_}});
    }
  }

  const std::map<std::string, ExportedModel>& models_;
  const std::filesystem::path scene_dir_;
  const int64_t scene_id_;
  ordered_json* targets_;
  std::map<int, const ObjectRecord*> objects_;
  std::map<int, Scene> alone_;
  std::map<int, std::unique_ptr<EmbreeCaster>> casters_;
  ordered_json scene_camera_ = ordered_json::object(), scene_gt_ = ordered_json::object(),
               scene_gt_info_ = ordered_json::object(), scene_extra_ = ordered_json::object();
};

}  // namespace

int ExportBop(const std::string& db_path,
              const std::string& out_dir,
              const BopExportOptions& options) {
  DatasetDb dataset(db_path, DatasetDb::Mode::kReadOnly);
  const Catalog catalog = CatalogOfDataset(dataset, db_path, options.catalog);
  const std::filesystem::path root(out_dir);
  const std::map<std::string, ExportedModel> models = ExportModels(dataset, catalog, root, db_path);
  const std::vector<int64_t> room_ids = dataset.RoomIds();
  Progress progress("export bop", room_ids.size(), "rooms");
  int written = 0;
  bool camera_written = false;
  ordered_json targets = ordered_json::array();
  for (int64_t room_id : room_ids) {
    const RoomRecord room = dataset.ReadRoom(room_id, /*with_images=*/true);
    BopRoomWriter writer(room,
                         models,
                         root / EnumName(room.split) / Pad(room.id),
                         room.split == Split::kTest ? &targets : nullptr);
    for (const FrameRecord& frame : room.frames) {
      if (!camera_written) {
        WriteCameraJson(frame, root);
        camera_written = true;
      }
      writer.AddFrame(frame, db_path);
      ++written;
    }
    if (!room.frames.empty()) writer.Finish();
    progress.Advance();
  }
  progress.Finish();
  WriteFileAtomically((root / "test_targets_bop19.json").string(),
                      targets.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  return written;
}

}  // namespace furn
