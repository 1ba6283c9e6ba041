#include "workbench/detect_command.h"

#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "db/dataset_db.h"
#include "renderers/frame_io.h"

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

CameraIntrinsics IntrinsicsOf(const FrameRecord& frame) {
  CameraIntrinsics camera;
  camera.width = frame.width;
  camera.height = frame.height;
  camera.fx = frame.fx;
  camera.fy = frame.fy;
  camera.cx = frame.cx;
  camera.cy = frame.cy;
  return camera;
}

DetectionInput DetectionInputOf(const FrameRecord& frame, const std::string& what) {
  const CameraIntrinsics camera = IntrinsicsOf(frame);
  camera.Check();
  DetectionInput input;
  input.points = BackProject(DecodeDepthPng(frame.depth_noisy_png, what + " noisy depth"), camera);
  input.width = frame.width;
  input.height = frame.height;
  input.world_from_camera = frame.world_from_camera;
  return input;
}

LoadedScan LoadScan(const ScanSource& source) {
  const int given =
      !source.cloud_path.empty() + !source.depth_path.empty() + !source.db_path.empty();
  Require(given == 1, "give exactly one of --cloud, --depth or --db");
  LoadedScan scan;
  if (!source.cloud_path.empty()) {
    ScanCloud cloud = ReadPointCloudFile(source.cloud_path);
    Require(!cloud.points.empty(), source.cloud_path + ": the cloud is empty");
    scan.input.points = std::move(cloud.points);
    scan.input.width = cloud.width;
    scan.input.height = cloud.height;
    scan.camera = CameraIntrinsics::KinectV1();
    scan.description = source.cloud_path;
    return scan;
  }
  if (!source.depth_path.empty()) {
    Require(source.depth_scale > 0,
            "depth scale " + std::to_string(source.depth_scale) + " must be > 0");
    const DepthFrame frame = ReadDepthPng(source.depth_path, source.depth_scale);
    scan.camera = ParseIntrinsics(source.intrinsics, frame.width, frame.height);
    scan.input.points = BackProject(frame, scan.camera);
    scan.input.width = frame.width;
    scan.input.height = frame.height;
    scan.description = source.depth_path;
    return scan;
  }
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
  const std::string what = source.db_path + " frame " + std::to_string(frame->id);
  scan.camera = IntrinsicsOf(*frame);
  scan.input = DetectionInputOf(*frame, what);
  scan.description = what;
  for (const ObjectRecord& object : room.objects) {
    scan.ground_truth.push_back({object.furniture_class,
                                 object.reference_x,
                                 object.reference_y,
                                 object.yaw,
                                 object.width,
                                 object.depth});
  }
  return scan;
}

std::string DetectionJson(const DetectionResult& result, const LoadedScan& scan) {
  nlohmann::ordered_json detections = nlohmann::ordered_json::array();
  for (const Detection& d : result.detections) {
    detections.push_back({{"class", ClassName(d.furniture_class)},
                          {"x", d.x},
                          {"y", d.y},
                          {"z", d.z},
                          {"yaw", d.yaw},
                          {"model", d.model_name},
                          {"score", d.score},
                          {"vote_weight", d.vote_weight},
                          {"verification", d.verification},
                          {"covered_fraction", d.covered_fraction}});
  }
  nlohmann::ordered_json timings = nlohmann::ordered_json::object();
  for (const auto& [stage, ms] : result.timings_ms) timings[stage] = ms;
  const Eigen::Matrix4d pose = result.world_from_camera.matrix();
  nlohmann::ordered_json json{
      {"input", scan.description},
      {"frame", "world: floor at z = 0, z up; x, y, z of the footprint centre; yaw about z"},
      {"world_from_camera", std::vector<double>(pose.data(), pose.data() + 16)},
      {"world_from_camera_layout", "4x4 column-major"},
      {"floor_estimated", result.floor_estimated},
      {"points_in_range", result.input_points},
      {"points", result.points},
      {"segments", result.segments},
      {"detections", detections},
      {"timings_ms", timings}};
  return json.dump(2) + "\n";
}

}  // namespace furn
