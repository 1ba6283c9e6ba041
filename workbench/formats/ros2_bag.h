// ROS 2 bags (rosbag2's SQLite or MCAP storage, CDR messages): scans read
// from a bag's depth topic as `detect --bag` does for ROS 1, detections
// written back as visualization_msgs/MarkerArray and
// vision_msgs/Detection3DArray, and dataset frames exported for ROS 2 stacks
// to replay. No ROS installation is needed: the SQLite tables, MCAP files,
// metadata.yaml and CDR are read and written here, bounded like the ROS 1
// path (ros2_storage.h has the two storage formats).
//
// A ROS 2 bag is a folder (metadata.yaml and <name>_0.db3 or <name>_0.mcap,
// ...) or one .db3 or .mcap file: what `ros2 bag record` writes on Humble
// (sqlite3) and on Iron, Jazzy and later (mcap). The dispatchers at the end pick ROS 1 or ROS 2 by
// the path:
//
//   ForEachScanInBag(options, [&](const BagScan& scan) { ... });   // .bag or ROS 2
//   std::unique_ptr<FrameBagSink> out = OpenFrameBag("export_ros2");  // a folder: ROS 2
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "workbench/formats/ros2_storage.h"
#include "workbench/formats/rosbag_io.h"

namespace furn {

// True when `path` is a ROS 2 bag: a folder, or a file ending in .db3 or .mcap.
bool IsRos2Bag(const std::string& path);

// ForEachBagScan of a ROS 2 bag (same options, same scans, same errors).
int ForEachRos2BagScan(const BagScanOptions& options,
                       const std::function<void(const BagScan&)>& each);

// Every message of a bag in time order (for tests and copies); bounded as
// the scan reader.
void ForEachRos2Message(const std::string& bag,
                        const std::function<void(const Ros2Message&)>& each);

// Writes a ROS 2 bag folder: <out>/<name>_0.db3 (the Humble layout, schema
// 3) or <out>/<name>_0.mcap (chunked, indexed, with a summary, as
// rosbag2's MCAP plugin writes), and metadata.yaml (version 5). Every topic
// carries its offered QoS (transient local for /tf_static) and, in MCAP, its
// message definition. Written into <out>.partial-<pid> and moved into place
// by Finish(); an existing <out> is replaced only when it is a ROS 2 bag
// folder. Destroyed unfinished, it leaves nothing.
class Ros2BagWriter {
 public:
  explicit Ros2BagWriter(const std::string& out,
                         Ros2Storage storage = Ros2Storage::kSqlite3,
                         McapCompression compression = McapCompression::kZstd);
  ~Ros2BagWriter();
  Ros2BagWriter(const Ros2BagWriter&) = delete;
  Ros2BagWriter& operator=(const Ros2BagWriter&) = delete;
  void Write(const std::string& topic,
             const std::string& type,
             int64_t time_ns,
             const std::vector<uint8_t>& cdr);
  // A copy of a message read from a bag, with its topic's QoS and schema.
  void Write(const Ros2Message& message);
  // Returns the messages written.
  int64_t Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The ROS 2 DetectionBagSink: a copy of the input bag with, per scan, a
// MarkerArray on `marker_topic` and a Detection3DArray on <marker_topic>_3d,
// in the input's storage (MCAP with the input's chunk compression, or SQLite).
class Ros2DetectionWriter : public DetectionBagSink {
 public:
  Ros2DetectionWriter(const std::string& in_bag,
                      const std::string& out_bag,
                      std::string world_frame,
                      std::string marker_topic = "/furnidet/detections");
  ~Ros2DetectionWriter() override;
  void Add(const BagScan& scan, const DetectionResult& result, const TrainedModel& model) override;
  void Finish() override;

 private:
  std::string in_bag_, world_frame_, marker_topic_;
  std::pair<Ros2Storage, McapCompression> format_;  // the input's: what the copy is written as
  Ros2BagWriter out_;
};

// The ROS 2 FrameBagSink: the topics of FrameBagWriter, as ROS 2 types.
class Ros2FrameWriter : public FrameBagSink {
 public:
  explicit Ros2FrameWriter(const std::string& out_bag, Ros2Storage storage = Ros2Storage::kSqlite3)
      : out_(out_bag, storage) {}
  void Write(const RoomRecord& room, const FrameRecord& frame, const std::string& where) override;
  int Finish() override;

 private:
  Ros2BagWriter out_;
  int frames_ = 0;
};

// Any bag: ROS 2 when IsRos2Bag, else ROS 1.
int ForEachScanInBag(const BagScanOptions& options,
                     const std::function<void(const BagScan&)>& each);
std::unique_ptr<DetectionBagSink> OpenDetectionBag(const std::string& in_bag,
                                                   const std::string& out_bag,
                                                   const std::string& world_frame);
// A ".bag" path: ROS 1; anything else: a ROS 2 bag folder of `storage`.
std::unique_ptr<FrameBagSink> OpenFrameBag(const std::string& out_bag,
                                           Ros2Storage storage = Ros2Storage::kSqlite3);

}  // namespace furn
