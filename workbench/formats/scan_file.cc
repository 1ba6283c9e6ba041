#include "workbench/formats/scan_file.h"

#include <glob.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/geometry/render_compare.h"
#include "core/geometry/scan_fusion.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "workbench/formats/camera_file.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/point_cloud_file.h"
#include "workbench/formats/real_labels.h"

namespace furn {

CameraIntrinsics ParseIntrinsics(const std::string& text, int width, int height) {
  if (text == "kinect1") {
    CameraIntrinsics camera = CameraIntrinsics::KinectV1();
    Require(camera.width == width && camera.height == height,
            "intrinsics kinect1 are for 640x480 images, but the image is " + std::to_string(width) +
                "x" + std::to_string(height));
    return camera;
  }
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    try {
      size_t used = 0;
      values.push_back(std::stod(item, &used));
      Require(used == item.size(), "");
    } catch (const std::exception&) {
      values.clear();
      break;
    }
  }
  Require(values.size() == 4,
          "intrinsics '" + text + "' must be kinect1 or fx,fy,cx,cy (four numbers)");
  CameraIntrinsics camera;
  camera.width = width;
  camera.height = height;
  camera.fx = values[0];
  camera.fy = values[1];
  camera.cx = values[2];
  camera.cy = values[3];
  camera.Check();
  return camera;
}

constexpr double kMaxFusedSensorDistanceM = 50;

LoadedScan FuseLoadedScans(const std::vector<LoadedScan>& scans,
                           const std::optional<ScanRegistrationOptions>& registration) {
  Require(!scans.empty(), "--fuse needs scans");
  std::vector<DetectionInput> inputs;
  std::string names;
  for (const LoadedScan& scan : scans) {
    Require(scan.input.world_from_camera.has_value() && !scan.label_from_camera,
            scan.description +
                ": --fuse needs every scan's pose in one floor-aligned frame (a world-frame "
                "cloud with its VIEWPOINT and --floor-aligned, or --world-from-camera)");
    inputs.push_back(scan.input);
    names += (names.empty() ? "" : ", ") + scan.description;
  }
  // Scans of one place: a sensor far from the last one's sees nothing the
  // detection keeps (its points lie beyond the range and would be dropped).
  const Eigen::Vector3d reference_sensor = scans.back().input.world_from_camera->translation();
  for (const LoadedScan& scan : scans) {
    const double apart = (scan.input.world_from_camera->translation() - reference_sensor).norm();
    Require(apart <= kMaxFusedSensorDistanceM,
            scan.description + ": --fuse: its sensor is " + std::to_string(apart) +
                " m from the last scan's; fused scans must be of one place (within " +
                std::to_string(static_cast<int>(kMaxFusedSensorDistanceM)) + " m)");
  }
  LoadedScan fused = scans.back();
  const size_t reference = inputs.size() - 1;
  if (registration) inputs = WithRegisteredPoses(std::move(inputs), reference, *registration);
  fused.input = FuseScans(inputs, reference);
  fused.ground_truth.clear();
  fused.description = std::to_string(scans.size()) + " scans fused (" + names + "), seen from " +
                      scans.back().description;
  return fused;
}

namespace {

// A look-at camera (optical frame) at `sensor` facing the horizontal
// direction of `target`: for floor-aligned unorganised clouds, whose camera
// orientation nothing uses but the camera frame's range test.
Eigen::Isometry3d CameraFacing(const Eigen::Vector3d& sensor, const Eigen::Vector3d& target) {
  Eigen::Vector3d forward = target - sensor;
  forward.z() = 0;
  if (forward.norm() < 1e-6) forward = Eigen::Vector3d::UnitX();
  forward.normalize();
  const Eigen::Vector3d down = -Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d right = down.cross(forward);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear().col(0) = right;
  pose.linear().col(1) = down;
  pose.linear().col(2) = forward;
  pose.translation() = sensor;
  return pose;
}

// Whether a VIEWPOINT can be the camera's pose: a cloud in the camera frame
// has most points in front (z > 0); a pose whose inverse puts most of them
// behind, while as given they lie in front, is a display convention.
bool ViewpointIsCameraPose(const ScanCloud& cloud, const Eigen::Isometry3d& viewpoint) {
  const Eigen::Isometry3f camera_from_world = viewpoint.inverse().cast<float>();
  size_t finite = 0, front_as_given = 0, front_posed = 0;
  for (const Eigen::Vector3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    ++finite;
    front_as_given += p.z() > 0;
    front_posed += (camera_from_world * p).z() > 0;
  }
  return !(2 * front_posed < finite && 2 * front_as_given > finite);
}

void CloudFromWorld(ScanCloud cloud, const ScanSource& source, LoadedScan* scan) {
  const std::string& path = source.cloud_path;
  std::optional<Eigen::Isometry3d> pose;
  if (!source.world_from_camera.empty()) {
    pose = ParsePose(source.world_from_camera, "--world-from-camera");
    scan->pose_source = "--world-from-camera";
  } else if (cloud.viewpoint) {
    if (!source.floor_aligned && !ViewpointIsCameraPose(cloud, *cloud.viewpoint)) {
      // OpenNI-era PCDs store "0 0 0 0 1 0 0", a turn of the viewer's
      // camera, with points already in the optical frame.
      scan->pose_source =
          "camera frame (the PCD VIEWPOINT, a rotation that would put the "
          "points behind the camera, is ignored)";
    } else {
      pose = cloud.viewpoint;
      scan->pose_source = "the PCD VIEWPOINT";
    }
  }
  if (source.floor_aligned) {
    // An organised grid fixes the camera exactly; it wins over a VIEWPOINT,
    // whose orientation may follow another convention than the optical
    // frame's, but not over a pose the user typed.
    if (cloud.width * cloud.height > 0 && source.world_from_camera.empty()) {
      if (const std::optional<OrganisedCloudCamera> camera =
              CameraOfOrganisedCloud(cloud.points, cloud.width, cloud.height)) {
        pose = camera->world_from_camera;
        scan->pose_source = "estimated from the organised cloud";
      }
    }
    if (!pose && !source.sensor.empty()) {
      Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
      int finite = 0;
      for (const Eigen::Vector3f& p : cloud.points) {
        if (!p.allFinite()) continue;
        centroid += p.cast<double>();
        ++finite;
      }
      Require(finite > 0, path + ": the cloud has no finite point");
      pose = CameraFacing(ParsePosition(source.sensor, "--sensor"), centroid / finite);
      scan->pose_source = "--sensor";
    }
    Require(pose.has_value(),
            path +
                ": a floor-aligned unorganised cloud needs the sensor position: --sensor "
                "x,y,z, --world-from-camera or a PCD VIEWPOINT");
  } else {
    Require(source.sensor.empty(), "--sensor applies to floor-aligned clouds (--floor-aligned)");
  }
  if (pose) {
    const Eigen::Isometry3f camera_from_world = pose->inverse().cast<float>();
    for (Eigen::Vector3f& p : cloud.points) {
      if (p.allFinite()) p = camera_from_world * p;
    }
    if (source.floor_aligned) {
      scan->input.world_from_camera = *pose;
    } else {
      scan->pose_source += " (to the camera frame; floor estimated)";
    }
  }
  scan->input.points = std::move(cloud.points);
  scan->input.width = cloud.width;
  scan->input.height = cloud.height;
}

// The image id of a BOP depth file: its name's number (000042.png -> 42).
std::optional<int64_t> BopImageId(const std::string& path) {
  const std::string name = std::filesystem::path(path).stem().string();
  if (name.empty() || name.size() > 12 ||
      !std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  return std::stoll(name);
}

}  // namespace

namespace {

LoadedScan LoadCloudScan(const ScanSource& source) {
  const bool world_options =
      !source.world_from_camera.empty() || source.floor_aligned || !source.sensor.empty();
  LoadedScan scan;
  ScanCloud cloud = ReadPointCloudFile(source.cloud_path);
  Require(!cloud.points.empty(), source.cloud_path + ": the cloud is empty");
  scan.camera = CameraIntrinsics::KinectV1();
  scan.description = source.cloud_path;
  if (world_options || cloud.viewpoint) {
    CloudFromWorld(std::move(cloud), source, &scan);
  } else {
    scan.input.points = std::move(cloud.points);
    scan.input.width = cloud.width;
    scan.input.height = cloud.height;
  }
  if (scan.input.width * scan.input.height > 0) {
    // An organised cloud tells its own intrinsics (debug views, reports).
    if (const std::optional<PinholeIntrinsics> own =
            IntrinsicsOfOrganisedCloud(scan.input.points, scan.input.width, scan.input.height)) {
      const CameraIntrinsics fitted{
          scan.input.width, scan.input.height, own->fx, own->fy, own->cx, own->cy};
      if (own->fx > 0 && own->fy > 0 && own->cx >= 0 && own->cy >= 0 && own->cx < fitted.width &&
          own->cy < fitted.height)
        scan.camera = fitted;
      scan.camera_source = "organised cloud";
    }
  }
  return scan;
}

// The depth image's camera: the camera file's (sized to the image), else
// --intrinsics.
CameraIntrinsics CameraOfDepthImage(const ScanSource& source,
                                    const CameraFile& camera_file,
                                    const DepthFrame& frame) {
  if (source.camera_file.empty())
    return ParseIntrinsics(source.intrinsics, frame.width, frame.height);
  CameraIntrinsics camera = camera_file.camera;
  Require((camera.width == 0 && camera.height == 0) ||
              (camera.width == frame.width && camera.height == frame.height),
          source.camera_file + " is for " + std::to_string(camera.width) + "x" +
              std::to_string(camera.height) + " images, but " + source.depth_path + " is " +
              std::to_string(frame.width) + "x" + std::to_string(frame.height));
  camera.width = frame.width;
  camera.height = frame.height;
  camera.Check();
  return camera;
}

LoadedScan LoadDepthScan(const ScanSource& source) {
  LoadedScan scan;
  std::optional<double> units;
  if (source.depth_scale > 0) units = source.depth_scale;
  CameraFile camera_file;
  if (!source.camera_file.empty()) {
    camera_file = ReadCameraFile(source.camera_file,
                                 source.image_id ? source.image_id : BopImageId(source.depth_path));
    if (!units) units = camera_file.units_per_metre;
  }
  const DepthFrame frame = ReadDepthImage(source.depth_path, units);
  scan.camera = CameraOfDepthImage(source, camera_file, frame);
  scan.camera_source = !source.camera_file.empty()      ? "camera file"
                       : source.intrinsics == "kinect1" ? "kinect1"
                                                        : "intrinsics";
  scan.input.points = BackProject(frame, scan.camera);
  scan.input.width = frame.width;
  scan.input.height = frame.height;
  scan.description = source.depth_path;
  // A depth image's points are in the camera frame; a pose helps only as
  // the camera's pose in the detector's floor-aligned world.
  Require(source.world_from_camera.empty() == !source.floor_aligned,
          source.depth_path +
              ": with a depth image, --world-from-camera (the camera's pose "
              "in a floor-aligned world) and --floor-aligned go together");
  if (source.floor_aligned) {
    scan.input.world_from_camera = ParsePose(source.world_from_camera, "--world-from-camera");
    scan.pose_source = "--world-from-camera";
  }
  return scan;
}

LoadedScan LoadDatasetFrame(const ScanSource& source) {
  Require(source.frame_id >= 0, "--db needs --frame ID (a frame id of that database)");
  DatasetDb db(source.db_path, DatasetDb::Mode::kReadOnly);
  const std::optional<int64_t> room_id = db.RoomOfFrame(source.frame_id);
  Require(room_id.has_value(),
          source.db_path + ": no frame with id " + std::to_string(source.frame_id));
  const RoomRecord room = db.ReadRoom(*room_id, /*with_images=*/true);
  const FrameRecord* frame = nullptr;
  for (const FrameRecord& f : room.frames) {
    if (f.id == source.frame_id) frame = &f;
  }
  Require(
      frame != nullptr,
      source.db_path + ": frame " + std::to_string(source.frame_id) + " is missing from its room");
  LoadedScan scan;
  const std::string what = source.db_path + " frame " + std::to_string(frame->id);
  scan.camera = IntrinsicsOf(*frame);
  scan.camera_source = "dataset frame";
  const std::optional<std::string> generation = db.GenerationOptions();
  const bool estimated_pose =
      generation && FramesWithEstimatedPose(*generation).count(frame->id) > 0;
  scan.input = RoomFrameInput(room, *frame, source.fusion, estimated_pose, source.db_path);
  scan.description = what;
  scan.dataset_frame = frame->id;
  if (source.fusion.room_frames && room.frames.size() > 1)
    scan.description +=
        " with its room's " + std::to_string(room.frames.size() - 1) + " other frames fused";
  if (estimated_pose) scan.label_from_camera = frame->world_from_camera;
  for (const ObjectRecord& object : room.objects) {
    double visibility = 0;  // an object the frame does not list is out of view
    for (const FrameObjectRecord& seen : frame->objects) {
      if (seen.instance_id == object.instance_id) visibility = seen.visibility;
    }
    scan.ground_truth.push_back(
        {object.Footprint(), object.furniture_class, object.height, object.model_id, visibility});
  }
  return scan;
}

// "--cloud, --depth or --db" (each flag, those that take `rule`, if given).
std::string FlagList(bool (*rule)(const ScanKind&) = nullptr) {
  std::vector<std::string> flags;
  for (const ScanKind& kind : ScanKinds()) {
    if (!rule || rule(kind)) flags.push_back(kind.flag);
  }
  std::string text;
  for (size_t i = 0; i < flags.size(); ++i)
    text += (i == 0 ? "" : i + 1 == flags.size() ? " or " : ", ") + flags[i];
  return text;
}

// The kinds whose path `source` sets, in the table's order.
std::vector<const ScanKind*> NamedKinds(const ScanSource& source) {
  std::vector<const ScanKind*> named;
  for (const ScanKind& kind : ScanKinds()) {
    if (!(source.*kind.path).empty()) named.push_back(&kind);
  }
  return named;
}

}  // namespace

const std::vector<ScanKind>& ScanKinds() {
  static const std::vector<ScanKind> kinds = {
      {"cloud", "--cloud", &ScanSource::cloud_path, {"pcd", "ply"}, true, true, LoadCloudScan},
      {"depth image",
       "--depth",
       &ScanSource::depth_path,
       {"png", "tif", "tiff", "exr"},
       true,
       false,
       LoadDepthScan},
      {"dataset frame", "--db", &ScanSource::db_path, {}, false, false, LoadDatasetFrame},
  };
  return kinds;
}

const ScanKind& KindOf(const ScanSource& source) {
  const std::vector<const ScanKind*> named = NamedKinds(source);
  Require(named.size() == 1, "give exactly one of " + FlagList() + " (or inputs)");
  return *named[0];
}

const ScanKind* KindOfFile(const std::string& path) {
  const std::string extension = FileExtension(path);
  for (const ScanKind& kind : ScanKinds()) {
    for (const std::string& e : kind.extensions) {
      if (e == extension) return &kind;
    }
  }
  return nullptr;
}

bool NamesAScan(const ScanSource& source) { return !NamedKinds(source).empty(); }

ScanSource WithoutScan(ScanSource source) {
  for (const ScanKind& kind : ScanKinds()) (source.*kind.path).clear();
  return source;
}

LoadedScan LoadScan(const ScanSource& source) {
  const ScanKind& kind = KindOf(source);
  if (source.depth_scale != 0) CheckUnitsPerMetre(source.depth_scale, "--depth-scale");
  Require(kind.takes_sensor || source.sensor.empty(), "--sensor applies to point clouds");
  Require(kind.takes_world_pose || (source.world_from_camera.empty() && !source.floor_aligned),
          std::string("--world-from-camera applies to ") +
              FlagList([](const ScanKind& k) { return k.takes_world_pose; }) + " scans, not " +
              kind.flag);
  return kind.load(source);
}

std::vector<GroundTruthFootprint> GroundTruthInDetectorFrame(const LoadedScan& scan,
                                                             const DetectionResult& result) {
  std::vector<GroundTruthFootprint> ground_truth = scan.ground_truth;
  if (!scan.label_from_camera || result.status != DetectionStatus::kDetected) return ground_truth;
  const Eigen::Isometry3d to_detector =
      result.world_from_camera * scan.label_from_camera->inverse();
  for (GroundTruthFootprint& truth : ground_truth) {
    truth.box() = MovedBox(truth.box(), to_detector);
  }
  return ground_truth;
}

std::string ScanSourceName(const ScanSource& source) {
  const std::vector<const ScanKind*> named = NamedKinds(source);
  if (named.empty()) return "";
  const std::string& path = source.*named[0]->path;
  return named[0]->path == &ScanSource::db_path ? path + " frame " + std::to_string(source.frame_id)
                                                : path;
}

}  // namespace furn
