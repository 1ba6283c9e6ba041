#include "workbench/formats/dataset_frame.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/util/error.h"
#include "core/util/random.h"
#include "workbench/formats/depth_png.h"

namespace furn {

void SetIntrinsics(const CameraIntrinsics& camera, FrameRecord* frame) {
  frame->width = camera.width;
  frame->height = camera.height;
  frame->fx = camera.fx;
  frame->fy = camera.fy;
  frame->cx = camera.cx;
  frame->cy = camera.cy;
}

CameraIntrinsics IntrinsicsOf(const FrameRecord& frame) {
  return {frame.width, frame.height, frame.fx, frame.fy, frame.cx, frame.cy};
}

void FrameFusion::Check() const {
  CheckPoseErrorSpreads(pose_noise_m, pose_noise_deg, "--fuse-pose-noise:");
  Require(room_frames || !HasPoseError(),
          "--fuse-pose-noise applies to fused frames (--fuse-room-frames)");
  Require(room_frames || !register_poses,
          "--fuse-register applies to fused frames (--fuse-room-frames)");
  Require(register_poses || !planar, "--fuse-planar applies to --fuse-register");
}

std::optional<ScanRegistrationOptions> FrameFusion::Registration() const {
  if (!register_poses) return std::nullopt;
  ScanRegistrationOptions options;
  options.planar = planar;
  return options;
}

nlohmann::json FrameFusion::Json() const {
  if (!room_frames) return nullptr;
  nlohmann::ordered_json json{{"room_frames", true},
                              {"pose_noise_m", pose_noise_m},
                              {"pose_noise_deg", pose_noise_deg},
                              {"register", register_poses}};
  // Only when set: runs stored before they existed read the same.
  if (planar_noise) json["planar_noise"] = true;
  if (planar) json["planar"] = true;
  return json;
}

FrameFusion FrameFusion::FromJson(const nlohmann::json& json, const std::string& what) {
  FrameFusion fusion;
  if (json.is_null()) return fusion;
  try {
    fusion.room_frames = json.at("room_frames").get<bool>();
    fusion.pose_noise_m = json.at("pose_noise_m").get<double>();
    fusion.pose_noise_deg = json.at("pose_noise_deg").get<double>();
    fusion.register_poses = json.value("register", false);
    fusion.planar_noise = json.value("planar_noise", false);
    fusion.planar = json.value("planar", false);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(what + ": fusion options: " + e.what());
  }
  try {  // stored options name no flag: the file and its field do
    CheckPoseErrorSpreads(fusion.pose_noise_m, fusion.pose_noise_deg, "pose_noise");
    fusion.Check();
  } catch (const InputError& e) {
    throw InputError(what + ": stored fusion options out of range (" + e.what() + ")");
  }
  return fusion;
}

void ParsePoseNoise(const std::string& text, FrameFusion* fusion, const std::string& flag) {
  const std::string rule = flag + " '" + text + "' must be M,DEG or M,DEG,planar (e.g. 0.02,1)";
  std::vector<std::string> fields(1);
  for (char c : text) {
    if (c == ',')
      fields.emplace_back();
    else
      fields.back() += c;
  }
  Require(fields.size() == 2 || (fields.size() == 3 && fields[2] == "planar"), rule);
  try {
    size_t used_m = 0, used_deg = 0;
    fusion->pose_noise_m = std::stod(fields[0], &used_m);
    fusion->pose_noise_deg = std::stod(fields[1], &used_deg);
    Require(used_m == fields[0].size() && used_deg == fields[1].size(), rule);
  } catch (const std::logic_error&) {
    throw InputError(rule);
  }
  fusion->planar_noise = fields.size() == 3;
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

std::vector<DetectionInput> RoomScans(const RoomRecord& room,
                                      const FrameRecord& frame,
                                      const FrameFusion& fusion,
                                      const std::string& db_path,
                                      size_t* reference) {
  std::vector<DetectionInput> scans;
  for (const FrameRecord& other : room.frames) {
    if (other.id == frame.id) *reference = scans.size();
    scans.push_back(DetectionInputOf(other, db_path + " frame " + std::to_string(other.id)));
  }
  PerturbRoomMates(room, *reference, fusion, &scans);
  return scans;
}

void PerturbRoomMates(const RoomRecord& room,
                      size_t reference,
                      const FrameFusion& fusion,
                      std::vector<DetectionInput>* scans) {
  if (!fusion.HasPoseError()) return;
  Require(scans->size() == room.frames.size() && reference < scans->size(),
          "room " + std::to_string(room.id) + ": " + std::to_string(scans->size()) +
              " scans for its " + std::to_string(room.frames.size()) + " frames");
  for (size_t i = 0; i < scans->size(); ++i) {
    if (i == reference) continue;
    FastRng rng(
        DeriveSeed(room.frames[reference].seed, static_cast<uint64_t>(room.frames[i].frame_index)));
    DetectionInput& scan = (*scans)[i];
    scan.world_from_camera = PerturbedPose(*scan.world_from_camera,
                                           fusion.pose_noise_m,
                                           fusion.pose_noise_deg * M_PI / 180,
                                           rng,
                                           fusion.planar_noise);
  }
}

DetectionInput RoomFrameInput(const RoomRecord& room,
                              const FrameRecord& frame,
                              const FrameFusion& fusion,
                              bool estimated_pose,
                              const std::string& db_path) {
  const std::string what = db_path + " frame " + std::to_string(frame.id);
  if (!fusion.room_frames || room.frames.size() < 2) {
    DetectionInput input = DetectionInputOf(frame, what);
    if (estimated_pose) input.world_from_camera.reset();
    return input;
  }
  Require(!estimated_pose,
          what + ": its floor is estimated, and fusing a room's frames needs their poses");
  size_t reference = 0;
  std::vector<DetectionInput> scans = RoomScans(room, frame, fusion, db_path, &reference);
  if (const std::optional<ScanRegistrationOptions> registration = fusion.Registration())
    scans = WithRegisteredPoses(std::move(scans), reference, *registration);
  return FuseScans(scans, reference);
}

}  // namespace furn
