// ROS 1 bags: scans read from a bag's depth topics (sensor_msgs/PointCloud2,
// or sensor_msgs/Image with its CameraInfo) with the camera's pose from /tf,
// detections written back as visualization_msgs/MarkerArray, and a dataset
// exported as a bag (depth images, CameraInfo, TF of the camera, ground truth
// as markers) for ROS stacks to replay.
//
//   BagScanOptions options;
//   options.bag_path = "office.bag";
//   options.topic = "/camera/depth/image_raw";
//   ForEachBagScan(options, [&](const BagScan& scan) { ... detector.Detect(scan.loaded.input) });
//
// ROS headers stay in rosbag_io.cc. Built only with FURN_WITH_ROS (Debian's
// librosbag-dev and message packages); otherwise every entry point throws
// InputError saying so.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/detector/detector.h"
#include "db/dataset_db.h"
#include "workbench/formats/scan_file.h"

namespace furn {

struct BagScanOptions {
  std::string bag_path;
  // A sensor_msgs/PointCloud2 topic (points in the message's frame, an
  // optical camera frame, metres) or a sensor_msgs/Image topic (16UC1/mono16
  // in 1/depth_scale m, or 32FC1 in m).
  std::string topic;
  // The CameraInfo of an Image topic; "" : <the image topic's namespace>/camera_info.
  std::string camera_info_topic;
  // A TF frame that is floor-aligned (z up, floor at z = 0): when /tf or
  // /tf_static connect it to a message's frame, that pose is used and the
  // floor is not searched. "" : never; the floor is found in every scan.
  std::string world_frame = "world";
  double depth_scale = 0;  // units per metre of integer images; 0: 1000 (millimetres)
};

struct BagScan {
  LoadedScan loaded;  // input, description, camera, pose_source
  std::string topic;
  std::string frame_id;  // the message's header.frame_id
  double stamp = 0;      // header stamp, seconds
  double bag_time = 0;   // when the bag recorded it, seconds
  uint32_t seq = 0;      // header.seq (a dataset export puts the frame id here)
  bool pose_from_tf = false;
  // When the bag has TF but no chain from the message's frame to
  // world_frame: why, naming the TF tree's roots (the frames --tf-world
  // could name); empty otherwise.
  std::string tf_miss;
  int total = 0;  // messages on the topic
};

// Calls `each` for every message of the topic, in bag order. Throws
// InputError naming the bag, topic and message for an unreadable bag, a
// missing topic, a message type or encoding it cannot use, or a malformed
// message. Returns the number of scans.
int ForEachBagScan(const BagScanOptions& options, const std::function<void(const BagScan&)>& each);

// Where `detect --bag --out-bag` writes each scan's detections (ROS 1 or 2).
class DetectionBagSink {
 public:
  virtual ~DetectionBagSink() = default;
  // Markers of one scan's detections, stamped as its message. In the world
  // frame when its pose came from TF, else in the message's own frame.
  virtual void Add(const BagScan& scan,
                   const DetectionResult& result,
                   const TrainedModel& model) = 0;
  // Copies every message of the input bag and moves the output into place.
  virtual void Finish() = 0;
};

// Where `dataset export --format rosbag` writes frames (ROS 1 or 2).
class FrameBagSink {
 public:
  virtual ~FrameBagSink() = default;
  // `where` names the frame in errors.
  virtual void Write(const RoomRecord& room,
                     const FrameRecord& frame,
                     const std::string& where) = 0;
  // Returns the frames written.
  virtual int Finish() = 0;
};

// A copy of a bag with one visualization_msgs/MarkerArray per scan added on
// `marker_topic` (cubes of the fitted models' boxes coloured by class, and
// labels); written to a temporary name and renamed by Finish.
class BagMarkerWriter : public DetectionBagSink {
 public:
  // `world_frame`: the TF frame of scans whose pose came from TF
  // (BagScanOptions::world_frame).
  BagMarkerWriter(const std::string& in_bag,
                  const std::string& out_bag,
                  std::string world_frame,
                  std::string marker_topic = "/furnidet/detections");
  ~BagMarkerWriter() override;
  BagMarkerWriter(const BagMarkerWriter&) = delete;
  BagMarkerWriter& operator=(const BagMarkerWriter&) = delete;
  void Add(const BagScan& scan, const DetectionResult& result, const TrainedModel& model) override;
  void Finish() override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Dataset frames as a Kinect driver would record them, with their truth:
// per frame /camera/depth/image_raw (16UC1, mm; header.seq = the frame id),
// /camera/depth/camera_info,
// /camera/depth/ids (16UC1 instance ids), /tf (world -> the camera's optical
// frame) and /furnidet/ground_truth (MarkerArray: a cube per object,
// namespace = its class or "clutter", id = its instance id). Frames 0.1 s
// apart from t = 1 s. Written to <out>.partial and moved into place by
// Finish(); destroyed unfinished, it leaves no file. Chunks are LZ4
// compressed unless `compress` is false.
class FrameBagWriter : public FrameBagSink {
 public:
  explicit FrameBagWriter(const std::string& out_bag, bool compress = true);
  ~FrameBagWriter() override;
  void Write(const RoomRecord& room, const FrameRecord& frame, const std::string& where) override;
  int Finish() override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace furn
