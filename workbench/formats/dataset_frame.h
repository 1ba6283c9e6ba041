// A frame of a dataset DB as the detector's input: its noisy depth
// back-projected with its known pose, alone or with the other frames of its
// room fused in (FrameFusion), their poses given a seeded random error first
// when an experiment asks for one (issue 37). ScanSource's db sources and the
// evaluation both come here.
//
//   DetectionInput input = RoomFrameInput(room, frame, fusion, false, "synth.db");
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/detector/detector.h"
#include "core/geometry/scan_fusion.h"
#include "db/dataset_db.h"
#include "renderers/camera.h"

namespace furn {

// A dataset frame detected with the other frames of its room fused in
// (issue 37; FuseScans): a table cut by one frame's side is often whole in
// another. Their known poses may be given a random error, as odometry or
// SLAM would have them, to measure what pose error costs.
struct FrameFusion {
  bool room_frames = false;
  double pose_noise_m = 0;    // sigma of the error along each axis
  double pose_noise_deg = 0;  // sigma of the rotation about each axis
  // The other frames' poses refined against this frame's points first
  // (RegisterScans), after the error is drawn.
  bool register_poses = false;
  // The error along x and y and about z only (a ground robot's odometry on
  // a fitted floor: height, roll and pitch right).
  bool planar_noise = false;
  // Registration corrects x, y and yaw only (ScanRegistrationOptions::planar).
  bool planar = false;

  // Throws InputError naming the value for a spread that is negative, not
  // finite, or beyond 1 m / 45 degrees, a spread or registration without
  // room_frames, or planar without registration.
  void Check() const;
  // Whether the other frames' poses get an error (either spread above 0).
  bool HasPoseError() const { return pose_noise_m != 0 || pose_noise_deg != 0; }
  // How registration refines the poses; nothing without register_poses.
  std::optional<ScanRegistrationOptions> Registration() const;
  // What the run stores: null when off, else {"room_frames", "pose_noise_m",
  // "pose_noise_deg", "register"}, with "planar_noise" and "planar" when
  // set; and back (InputError naming `what`).
  nlohmann::json Json() const;
  static FrameFusion FromJson(const nlohmann::json& json, const std::string& what);
};

// "M,DEG" or "M,DEG,planar" (the value of `flag`) into the fusion's
// spreads; InputError naming the flag otherwise.
void ParsePoseNoise(const std::string& text,
                    FrameFusion* fusion,
                    const std::string& flag = "--fuse-pose-noise");

// The intrinsics a dataset frame was rendered with, and their setter.
CameraIntrinsics IntrinsicsOf(const FrameRecord& frame);
void SetIntrinsics(const CameraIntrinsics& camera, FrameRecord* frame);

// Detection input of a dataset frame: its noisy depth back-projected, with
// its known pose. `what` names the frame in errors.
DetectionInput DetectionInputOf(const FrameRecord& frame, const std::string& what);

// The room's scans (one per frame of `room`, in its order) with every pose
// but scans[reference]'s given the fusion's random error, seeded by the
// reference frame's seed and the other's index: the same error every time.
// Nothing changes without an error.
void PerturbRoomMates(const RoomRecord& room,
                      size_t reference,
                      const FrameFusion& fusion,
                      std::vector<DetectionInput>* scans);

// Every frame of `frame`'s room as a scan (DetectionInputOf), the others'
// poses with the fusion's random error (PerturbRoomMates); `reference` is
// set to this frame's place among them.
std::vector<DetectionInput> RoomScans(const RoomRecord& room,
                                      const FrameRecord& frame,
                                      const FrameFusion& fusion,
                                      const std::string& db_path,
                                      size_t* reference);

// What a dataset frame is detected in: DetectionInputOf, without its pose
// when `estimated_pose` (the detector finds the floor); with
// fusion.room_frames and other frames in the room, every frame of the room
// in this frame's camera (RoomScans, then FuseScans; registered first with
// fusion.register_poses). Throws InputError naming the frame when fusion meets a
// frame whose floor is estimated: fusion needs known poses.
DetectionInput RoomFrameInput(const RoomRecord& room,
                              const FrameRecord& frame,
                              const FrameFusion& fusion,
                              bool estimated_pose,
                              const std::string& db_path);

}  // namespace furn
