#include "workbench/pipelines/import_real.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "core/geometry/mesh.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "reports/real_sheet.h"
#include "workbench/formats/camera_file.h"
#include "workbench/formats/depth_png.h"

namespace furn {
namespace {

std::vector<GroundTruthFootprint> Footprints(const RealScan& scan) {
  std::vector<GroundTruthFootprint> footprints;
  for (const RealObject& o : scan.objects) {
    footprints.push_back({{o.x, o.y, o.yaw ? *o.yaw : std::nan(""), o.size.x(), o.size.y()},
                          o.furniture_class,
                          o.size.z(),
                          "",
                          -1});
  }
  return footprints;
}

// One hand-labelled "model" per class: the paper's four and any other class
// the labels use.
std::set<FurnitureClass> LabelledClasses(const RealSet& set) {
  std::set<FurnitureClass> classes(kPaperClasses.begin(), kPaperClasses.end());
  for (const RealScan& scan : set.scans) {
    for (const RealObject& o : scan.objects) classes.insert(o.furniture_class);
  }
  return classes;
}

}  // namespace

namespace {

// A scan loaded, with the camera's pose in the labels' frame.
struct LoadedRealScan {
  const RealScan* scan;
  LoadedScan loaded;
  Eigen::Isometry3d label_from_camera;
  bool pose_known;
};

// One scan loaded, with the camera's pose in the labels' frame.
LoadedRealScan LoadRealScan(const RealScan& scan) {
  LoadedScan loaded = LoadScan(scan.source);
  const bool known = loaded.input.world_from_camera.has_value();
  const Eigen::Isometry3d pose = known ? *loaded.input.world_from_camera : *scan.label_frame;
  return {&scan, std::move(loaded), pose, known};
}

std::vector<ModelRecord> LabelModels(const RealSet& set) {
  std::vector<ModelRecord> models;
  for (FurnitureClass c : LabelledClasses(set)) {
    ModelRecord model;
    model.id = std::string("real/") + ClassName(c);
    model.furniture_class = c;
    model.content_hash = "labelled by hand";
    model.evaluation_only = true;
    models.push_back(model);
  }
  return models;
}

// The scan's depth through its camera (the nearest point per pixel), its
// labels as the room's objects; `in_label_frame` gets its points in the
// labels' frame (for the sheet).
RoomRecord RoomOfScan(const LoadedRealScan& entry,
                      int64_t room_id,
                      const std::string& set_path,
                      std::vector<Eigen::Vector3f>* in_label_frame) {
  const CameraIntrinsics& camera = entry.loaded.camera;
  DepthFrame depth;
  depth.Resize(camera.width, camera.height);
  depth.normals.clear();
  Eigen::Vector2d low(1e9, 1e9), high(-1e9, -1e9);
  for (const Eigen::Vector3f& p : entry.loaded.input.points) {
    if (!p.allFinite() || p.z() <= 0.05f) continue;
    const Eigen::Vector2d pixel = camera.Project(p.cast<double>());
    const int u = static_cast<int>(std::lround(pixel.x()));
    const int v = static_cast<int>(std::lround(pixel.y()));
    if (u < 0 || v < 0 || u >= camera.width || v >= camera.height) continue;
    float& z = depth.depth[static_cast<size_t>(v) * camera.width + u];
    if (z == 0 || p.z() < z) z = p.z();
    const Eigen::Vector3f w = entry.label_from_camera.cast<float>() * p;
    in_label_frame->push_back(w);
    low = low.cwiseMin(w.head<2>().cast<double>());
    high = high.cwiseMax(w.head<2>().cast<double>());
  }
  Require(!in_label_frame->empty(),
          set_path + ": scan '" + entry.scan->id + "' has no point in front of its camera");
  RoomRecord room;
  room.id = room_id;
  room.seed = 0;
  room.split = Split::kTest;
  room.width = high.x() - low.x();
  room.depth = high.y() - low.y();
  room.requested_furniture = room.placed_furniture = static_cast<int>(entry.scan->objects.size());
  FrameRecord frame;
  frame.id = room_id;
  frame.frame_index = 0;
  SetIntrinsics(camera, &frame);
  frame.world_from_camera = entry.label_from_camera;
  frame.depth_noisy_png = EncodeDepthPng(depth);
  frame.depth_ideal_png = frame.depth_noisy_png;  // a real scan has one depth
  frame.ids_png = EncodeIdPng(depth);
  frame.ids_noisy_png = frame.ids_png;
  ContentHasher hash;
  hash.Update(frame.depth_noisy_png.data(), frame.depth_noisy_png.size());
  frame.content_hash = hash.HexDigest();
  int instance = 0;
  for (const RealObject& o : entry.scan->objects) {
    ObjectRecord object;
    object.instance_id = ++instance;
    object.model_id = std::string("real/") + ClassName(o.furniture_class);
    object.furniture_class = o.furniture_class;
    object.x = object.reference_x = o.x;
    object.y = object.reference_y = o.y;
    object.yaw = o.yaw ? *o.yaw : 0;
    object.width = o.size.x();
    object.depth = o.size.y();
    object.height = o.size.z();
    room.objects.push_back(object);
    FrameObjectRecord seen;
    seen.instance_id = object.instance_id;
    seen.visibility = o.visibility;
    seen.in_frustum = true;
    frame.objects.push_back(seen);
  }
  room.frames.push_back(std::move(frame));
  return room;
}

// The frame's entry of the generation options: where it came from, and
// whether the detector must find its floor.
nlohmann::ordered_json FrameEntry(const LoadedRealScan& entry, int64_t room_id) {
  nlohmann::json defined = nlohmann::json::array();
  for (const RealObject& o : entry.scan->objects) defined.push_back(o.yaw.has_value());
  return {{"frame", room_id},
          {"id", entry.scan->id},
          {"pose", entry.pose_known ? "known" : "estimate"},
          {"input", entry.loaded.description},
          {"source", entry.scan->origin},
          {"licence", entry.scan->licence},
          {"yaw_defined", defined}};
}

}  // namespace

RealImportSummary ImportRealSet(const RealSet& set,
                                const std::string& db_path,
                                const std::string& sheet_dir) {
  Require(!std::filesystem::exists(db_path),
          db_path + ": exists; import-real writes a new dataset (remove it first)");
  const std::string temporary = db_path + ".partial";
  std::filesystem::remove(temporary);
  RealImportSummary summary;
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  // Scans load one at a time (a set of 800 Kinect frames would hold 3 GB of
  // points at once) into a temporary file: a bad one leaves no dataset.
  try {
    DatasetDb db(temporary, DatasetDb::Mode::kReadWrite);
    db.WriteModels(LabelModels(set));
    int64_t room_id = 0;
    Progress progress("import-real", set.scans.size(), "scans");
    for (const RealScan& scan : set.scans) {
      const LoadedRealScan entry = LoadRealScan(scan);
      ++room_id;
      std::vector<Eigen::Vector3f> in_label_frame;
      db.WriteRoom(RoomOfScan(entry, room_id, set.path, &in_label_frame));
      summary.objects += static_cast<int>(entry.scan->objects.size());
      frames.push_back(FrameEntry(entry, room_id));
      if (!sheet_dir.empty()) {
        std::filesystem::create_directories(sheet_dir);
        WriteRealScanSheet(in_label_frame,
                           entry.label_from_camera,
                           entry.loaded.camera,
                           Footprints(*entry.scan),
                           entry.scan->id,
                           (std::filesystem::path(sheet_dir) / (entry.scan->id + ".png")).string());
      }
      ++summary.frames;
      progress.Advance();
    }
    progress.Finish();
    db.SetGenerationOptions(nlohmann::ordered_json{
        {"kind", "real-set"},
        {"labels", set.path},
        {"frames", frames}}.dump());
  } catch (...) {
    RemoveDatabaseFiles(temporary);
    throw;
  }
  for (const char* suffix : {"-wal", "-shm"}) std::filesystem::remove(temporary + suffix);
  std::filesystem::rename(temporary, db_path);
  return summary;
}

}  // namespace furn
