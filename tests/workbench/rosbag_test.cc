// ROS 1 bags end to end: a dataset exported as a bag and read back (depth,
// intrinsics, TF pose, ground-truth markers), detection over the bag equal
// to detection over the dataset's frames, markers written back, a
// PointCloud2 bag written here, and bad bags refused with one line.
#include <gtest/gtest.h>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <unistd.h>
#include <yaml-cpp/yaml.h>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "db/sqlite.h"
#include "renderers/camera.h"
#include "tests/test_util.h"
#include "workbench/formats/bag_check.h"
#include "workbench/formats/cdr.h"
#include "workbench/formats/mcap.h"
#include "workbench/formats/ros2_bag.h"
#include "workbench/formats/ros2_messages.h"
#include "workbench/formats/ros_common.h"
#include "workbench/formats/rosbag_io.h"
#include "workbench/formats/scan_file.h"

namespace furn {
namespace {

testing::CommandResult Workbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
}

std::vector<nlohmann::json> JsonLines(const std::string& path) {
  std::vector<nlohmann::json> lines;
  std::istringstream in(ReadFileBytes(path));
  for (std::string line; std::getline(in, line);) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

class RosbagTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::ScratchDir());
    ASSERT_EQ(Workbench("generate --catalog procedural:4 --rooms 4 --frames 2 --seed 11 --quiet "
                        "--out " +
                        Db())
                  .exit_code,
              0);
    ASSERT_EQ(
        Workbench(
            "train --no-vote-net --catalog procedural:4 --azimuths 4 --words 20 --vocab kmeans "
            "--quiet --out " +
            Model())
            .exit_code,
        0);
    const testing::CommandResult exported =
        Workbench("dataset export " + Db() + " --format rosbag --out " + Bag());
    ASSERT_EQ(exported.exit_code, 0) << exported.output;
    ASSERT_NE(exported.output.find("wrote 8 frames"), std::string::npos) << exported.output;
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Db() { return *dir_ + "/s.db"; }
  static std::string Model() { return *dir_ + "/m.fcm"; }
  static std::string Bag() { return *dir_ + "/s.bag"; }
  // `detect --db --frame` detections of a frame: what evaluate computes for it.
  static nlohmann::json DetectFrame(int64_t frame) {
    const std::string out = *dir_ + "/frame" + std::to_string(frame) + ".json";
    const testing::CommandResult r =
        Workbench("detect --quiet --model " + Model() + " --db " + Db() + " --frame " +
                  std::to_string(frame) + " --out " + out);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return nlohmann::json::parse(ReadFileBytes(out))["detections"];
  }
  // A detection's floor point: detect's JSON (format 2) or a stored row's x, y.
  static std::array<double, 2> FloorPoint(const nlohmann::json& d) {
    if (d.contains("floor_point")) return {d["floor_point"][0], d["floor_point"][1]};
    return {d["x"].get<double>(), d["y"].get<double>()};
  }
  static void ExpectSameDetections(const nlohmann::json& a, const nlohmann::json& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i]["class"], b[i]["class"]);
      EXPECT_NEAR(FloorPoint(a[i])[0], FloorPoint(b[i])[0], 1e-6);
      EXPECT_NEAR(FloorPoint(a[i])[1], FloorPoint(b[i])[1], 1e-6);
      EXPECT_NEAR(a[i]["score"].get<double>(), b[i]["score"].get<double>(), 1e-6);
    }
  }
  static std::string* dir_;
};
std::string* RosbagTest::dir_ = nullptr;

TEST_F(RosbagTest, ExportedFramesReadBackAsTheDatasetHasThem) {
  DatasetDb dataset(Db(), DatasetDb::Mode::kReadOnly);
  std::map<int64_t, FrameRecord> frames;
  for (int64_t room : dataset.RoomIds()) {
    for (FrameRecord& frame : dataset.ReadRoom(room, true).frames) frames[frame.id] = frame;
  }
  BagScanOptions options;
  options.bag_path = Bag();
  options.topic = "/camera/depth/image_raw";
  int seen = 0;
  ForEachBagScan(options, [&](const BagScan& scan) {
    ASSERT_EQ(frames.count(scan.seq), 1u);
    const FrameRecord& frame = frames.at(scan.seq);
    const DetectionInput expected = DetectionInputOf(frame, "frame");
    ASSERT_EQ(scan.loaded.input.points.size(), expected.points.size());
    for (size_t i = 0; i < expected.points.size(); ++i) {
      const Eigen::Vector3f& a = scan.loaded.input.points[i];
      const Eigen::Vector3f& b = expected.points[i];
      ASSERT_EQ(a.allFinite(), b.allFinite()) << i;
      if (a.allFinite()) {
        ASSERT_LT((a - b).norm(), 1e-6f) << i;
      }
    }
    EXPECT_EQ(scan.loaded.camera.fx, frame.fx);
    EXPECT_EQ(scan.loaded.camera.cy, frame.cy);
    ASSERT_TRUE(scan.pose_from_tf);
    EXPECT_TRUE(scan.loaded.input.world_from_camera->isApprox(frame.world_from_camera, 1e-6));
    EXPECT_EQ(scan.total, 8);
    ++seen;
  });
  EXPECT_EQ(seen, 8);

  // Ground truth: a cube per object, namespace = class, id = instance, on the floor.
  rosbag::Bag bag(Bag(), rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/furnidet/ground_truth"));
  int arrays = 0;
  for (const rosbag::MessageInstance& m : view) {
    const auto truth = m.instantiate<visualization_msgs::MarkerArray>();
    ASSERT_TRUE(truth);
    ++arrays;
  }
  EXPECT_EQ(arrays, 8);
  // The TF tree a driver publishes: camera_link -> optical frame once on
  // /tf_static (latched), world -> camera_link per frame on /tf.
  rosbag::View statics(bag, rosbag::TopicQuery("/tf_static"));
  ASSERT_EQ(statics.size(), 1u);
  EXPECT_EQ(statics.begin()->getConnectionHeader()->at("latching"), "1");
  const auto fixed = statics.begin()->instantiate<tf2_msgs::TFMessage>();
  ASSERT_EQ(fixed->transforms.size(), 1u);
  EXPECT_EQ(fixed->transforms[0].header.frame_id, "camera_link");
  EXPECT_EQ(fixed->transforms[0].child_frame_id, "camera_depth_optical_frame");
  EXPECT_NEAR(fixed->transforms[0].transform.rotation.w, 0.5, 1e-12);
  EXPECT_NEAR(fixed->transforms[0].transform.rotation.x, -0.5, 1e-12);
  rosbag::View moving(bag, rosbag::TopicQuery("/tf"));
  EXPECT_EQ(moving.size(), 8u);
  EXPECT_EQ(moving.begin()->instantiate<tf2_msgs::TFMessage>()->transforms.at(0).child_frame_id,
            "camera_link");
  const RoomRecord room = dataset.ReadRoom(dataset.RoomIds().front(), false);
  const auto first = view.begin()->instantiate<visualization_msgs::MarkerArray>();
  ASSERT_EQ(first->markers.size(), room.objects.size() + 1);  // + DELETEALL
  EXPECT_EQ(first->markers[0].action, 3);
  for (size_t k = 0; k < room.objects.size(); ++k) {
    const ObjectRecord& object = room.objects[k];
    const visualization_msgs::Marker& box = first->markers[k + 1];
    EXPECT_EQ(box.ns, object.furniture_class ? ClassName(*object.furniture_class) : "clutter");
    EXPECT_EQ(box.id, object.instance_id);
    EXPECT_EQ(box.header.frame_id, "world");
    EXPECT_NEAR(box.pose.position.x, object.reference_x, 1e-9);
    EXPECT_NEAR(box.pose.position.y, object.reference_y, 1e-9);
    EXPECT_NEAR(box.pose.position.z, object.height / 2, 1e-9);
    // REP 103: the box's x is the object's front, the model's -y.
    const double yaw = 2 * std::atan2(box.pose.orientation.z, box.pose.orientation.w);
    EXPECT_NEAR(std::remainder(yaw - (object.yaw - M_PI / 2), 2 * M_PI), 0, 1e-6);
    EXPECT_NEAR(box.scale.x, object.depth, 1e-6);
    EXPECT_NEAR(box.scale.y, object.width, 1e-6);
    EXPECT_EQ(box.text, object.model_id);
  }
}

// A bag of messages none of which could be detected in (nothing within
// reach) fails as a batch of such files does: a line each, exit code 1.
TEST_F(RosbagTest, ABagWhoseMessagesAllFailExitsOne) {
  const std::string out = *dir_ + "/none.jsonl";
  const testing::CommandResult r =
      Workbench("detect --model " + Model() + " --bag " + Bag() +
                " --topic /camera/depth/image_raw --max-range 0.05 --out " + out);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("8 messages, 8 without points or floor"), std::string::npos) << r.output;
  EXPECT_EQ(JsonLines(out).size(), 8u);
}

// A --tf-world the bag's TF does not reach is a warning naming the tree's
// roots (an error with --strict); the boxes then name no TF frame.
TEST_F(RosbagTest, AnUnresolvedTfWorldIsAWarningOrWithStrictAnError) {
  const std::string out = *dir_ + "/odom.jsonl";
  const std::string base = "detect --model " + Model() + " --bag " + Bag() +
                           " --topic /camera/depth/image_raw --tf-world odom --max-range 0.05";
  const testing::CommandResult warned = Workbench(base + " --out " + out);
  EXPECT_NE(warned.output.find("warning: TF has no chain from camera_depth_optical_frame to "
                               "--tf-world 'odom' (the TF tree's roots: world)"),
            std::string::npos)
      << warned.output;
  for (const nlohmann::json& line : JsonLines(out)) EXPECT_TRUE(line["boxes_frame_id"].is_null());
  const testing::CommandResult strict = Workbench(base + " --strict --out " + out + ".strict");
  EXPECT_EQ(strict.exit_code, 1);
  EXPECT_NE(strict.output.find("(--strict; name a root with --tf-world)"), std::string::npos)
      << strict.output;
  EXPECT_FALSE(std::filesystem::exists(out + ".strict"));
}

TEST_F(RosbagTest, DetectionOverTheBagEqualsDetectionOverTheDatasetAndWritesMarkers) {
  const std::string out = *dir_ + "/bag.jsonl", marked = *dir_ + "/marked.bag";
  const testing::CommandResult r =
      Workbench("detect --model " + Model() + " --bag " + Bag() +
                " --topic /camera/depth/image_raw --out " + out + " --out-bag " + marked);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("8 messages, 0 without points or floor"), std::string::npos) << r.output;
  const std::vector<nlohmann::json> lines = JsonLines(out);
  ASSERT_EQ(lines.size(), 8u);
  std::vector<size_t> per_message;
  for (const nlohmann::json& line : lines) {
    EXPECT_EQ(line["pose_source"], "tf: world <- camera_depth_optical_frame");
    EXPECT_EQ(line["boxes_frame_id"], "world");
    EXPECT_EQ(line["topic"], "/camera/depth/image_raw");
    ExpectSameDetections(line["detections"], DetectFrame(line["seq"].get<int64_t>()));
    per_message.push_back(line["detections"].size());
  }
  // The marked bag: every message of the input, and a MarkerArray per scan,
  // compressed as its input (LZ4 from the exporter).
  EXPECT_EQ(CheckBagFile(Bag()), "lz4");
  EXPECT_EQ(CheckBagFile(marked), "lz4");
  EXPECT_LT(std::filesystem::file_size(marked), 2 * std::filesystem::file_size(Bag()));
  rosbag::Bag in(Bag(), rosbag::bagmode::Read), with(marked, rosbag::bagmode::Read);
  EXPECT_EQ(rosbag::View(with).size(), rosbag::View(in).size() + 8);
  rosbag::View markers(with, rosbag::TopicQuery("/furnidet/detections"));
  size_t k = 0, boxes = 0;
  for (const rosbag::MessageInstance& m : markers) {
    const auto array = m.instantiate<visualization_msgs::MarkerArray>();
    ASSERT_TRUE(array);
    ASSERT_LT(k, per_message.size());
    EXPECT_EQ(array->markers.size(), 1 + 2 * per_message[k]);  // DELETEALL, cube + label each
    for (size_t i = 1; i < array->markers.size(); i += 2) {
      EXPECT_EQ(array->markers[i].header.frame_id, "world");
      EXPECT_EQ(array->markers[i].type, visualization_msgs::Marker::CUBE);
      EXPECT_EQ(array->markers[i + 1].type, visualization_msgs::Marker::TEXT_VIEW_FACING);
      const nlohmann::json& d = lines[k]["detections"][(i - 1) / 2];
      EXPECT_NEAR(array->markers[i].pose.position.x, d["centre"][0].get<double>(), 1e-6);
      EXPECT_NEAR(array->markers[i].pose.position.z, d["centre"][2].get<double>(), 1e-6);
      ++boxes;
    }
    ++k;
  }
  EXPECT_EQ(k, 8u);
  EXPECT_GT(boxes, 0u);  // the procedural rooms give detections

  // And the same as the detections `evaluate` stores for those frames.
  const testing::CommandResult evaluated =
      Workbench("evaluate --quiet --split all --model " + Model() + " --db " + Db());
  ASSERT_EQ(evaluated.exit_code, 0) << evaluated.output;
  Database db(Db(), Database::Mode::kReadOnly);
  for (const nlohmann::json& line : lines) {
    Statement query(&db,
                    "SELECT class, x, y, score FROM run_detections WHERE frame_id = ? AND run_id = "
                    "(SELECT MAX(id) FROM runs) ORDER BY rowid");
    query.Bind(1, line["seq"].get<int64_t>());
    nlohmann::json stored = nlohmann::json::array();
    while (query.Step()) {
      stored.push_back({{"class", query.ColumnText(0)},
                        {"x", query.ColumnDouble(1)},
                        {"y", query.ColumnDouble(2)},
                        {"score", query.ColumnDouble(3)}});
    }
    ExpectSameDetections(line["detections"], stored);
  }
  EXPECT_FALSE(std::filesystem::exists(marked + ".partial"));
}

// ROS 2: the same dataset exported as a ROS 2 bag folder reads back as the
// ROS 1 bag does, frame for frame; detection over it gives the same lines
// and writes markers and vision_msgs/Detection3DArray beside a copy of it.
TEST_F(RosbagTest, Ros2BagsMatchTheRos1PathFrameForFrame) {
  const std::string ros2 = *dir_ + "/s_ros2";
  const testing::CommandResult exported =
      Workbench("dataset export " + Db() + " --format rosbag --out " + ros2);
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  ASSERT_TRUE(std::filesystem::exists(ros2 + "/metadata.yaml"));
  ASSERT_TRUE(std::filesystem::exists(ros2 + "/s_ros2_0.db3"));
  BagScanOptions options;
  options.topic = "/camera/depth/image_raw";
  std::vector<BagScan> one, two;
  options.bag_path = Bag();
  ForEachScanInBag(options, [&](const BagScan& scan) { one.push_back(scan); });
  options.bag_path = ros2;
  ForEachScanInBag(options, [&](const BagScan& scan) { two.push_back(scan); });
  ASSERT_EQ(one.size(), 8u);
  ASSERT_EQ(two.size(), one.size());
  for (size_t k = 0; k < one.size(); ++k) {
    EXPECT_EQ(two[k].frame_id, one[k].frame_id);
    EXPECT_NEAR(two[k].stamp, one[k].stamp, 1e-9);
    EXPECT_EQ(two[k].total, one[k].total);
    EXPECT_TRUE(two[k].pose_from_tf);
    ASSERT_EQ(two[k].loaded.input.points.size(), one[k].loaded.input.points.size());
    size_t differ = 0;  // NaN marks a pixel without depth in both
    for (size_t i = 0; i < one[k].loaded.input.points.size(); ++i) {
      const Eigen::Vector3f& p = one[k].loaded.input.points[i];
      const Eigen::Vector3f& q = two[k].loaded.input.points[i];
      differ += !(p == q) && !(p.hasNaN() && q.hasNaN());
    }
    EXPECT_EQ(differ, 0u) << "frame " << k;
    EXPECT_TRUE(two[k].loaded.input.world_from_camera->isApprox(
        *one[k].loaded.input.world_from_camera, 1e-12));
    EXPECT_EQ(two[k].loaded.camera.fx, one[k].loaded.camera.fx);
  }
  // Ground truth: the marker arrays carry the same bytes a ROS 2 reader decodes.
  std::map<std::string, int> per_topic;
  ForEachRos2Message(ros2, [&](const Ros2Message& m) { ++per_topic[m.topic]; });
  for (const char* topic : {"/tf",
                            "/camera/depth/camera_info",
                            "/camera/depth/image_raw",
                            "/camera/depth/ids",
                            "/furnidet/ground_truth"})
    EXPECT_EQ(per_topic[topic], 8) << topic;
  EXPECT_EQ(per_topic["/tf_static"], 1);
  // QoS as recorded from a driver: /tf_static transient local (1), the rest volatile (2).
  const YAML::Node info = YAML::LoadFile(ros2 + "/metadata.yaml")["rosbag2_bagfile_information"];
  for (const YAML::Node& topic : info["topics_with_message_count"]) {
    const std::string name = topic["topic_metadata"]["name"].as<std::string>();
    const YAML::Node qos =
        YAML::Load(topic["topic_metadata"]["offered_qos_profiles"].as<std::string>());
    ASSERT_TRUE(qos.IsSequence()) << name;
    EXPECT_EQ(qos[0]["durability"].as<int>(), name == "/tf_static" ? 1 : 2) << name;
    EXPECT_EQ(qos[0]["reliability"].as<int>(), 1) << name;
  }

  // Detection: the same JSON lines from either bag; the output bag holds the
  // input's messages, one MarkerArray and one Detection3DArray per scan.
  const std::string lines1 = *dir_ + "/r1.jsonl", lines2 = *dir_ + "/r2.jsonl";
  const std::string marked = *dir_ + "/marked_ros2";
  for (const auto& [bag, out, extra] : {std::tuple{Bag(), lines1, std::string()},
                                        std::tuple{ros2, lines2, " --out-bag " + marked}}) {
    const testing::CommandResult r =
        Workbench("detect --quiet --model " + Model() + " --bag " + bag +
                  " --topic /camera/depth/image_raw --out " + out + extra);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  const std::vector<nlohmann::json> a = JsonLines(lines1), b = JsonLines(lines2);
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k)
    ExpectSameDetections(a[k]["detections"], b[k]["detections"]);
  std::map<std::string, int> out_topics;
  size_t scan = 0, boxes = 0;
  ForEachRos2Message(marked, [&](const Ros2Message& m) {
    ++out_topics[m.topic];
    if (m.topic != "/furnidet/detections_3d") return;
    EXPECT_EQ(m.type, "vision_msgs/msg/Detection3DArray");
    // Detection3DArray: header, then per detection header, one hypothesis
    // (class, score, pose with covariance), the box (pose, size), id.
    CdrReader in(m.data.data(), m.data.size(), "detections_3d");
    auto header = [&] {
      in.Read<int32_t>();
      in.Read<uint32_t>();
      return in.String("frame_id");
    };
    EXPECT_EQ(header(), "world");
    const nlohmann::json& detections = b.at(scan)["detections"];
    ASSERT_EQ(in.SequenceLength("detections", 1), detections.size());
    size_t index = 0;
    for (const nlohmann::json& d : detections) {
      header();
      ASSERT_EQ(in.SequenceLength("results", 1), 1u);
      EXPECT_EQ(in.String("class_id"), d["class"].get<std::string>());
      EXPECT_NEAR(in.Read<double>(), d["score"].get<double>(), 1e-9);
      for (int i = 0; i < 7; ++i) in.Read<double>();
      EXPECT_EQ(in.Read<double>(), -1.0);  // covariance unknown, as sensor_msgs marks it
      for (int i = 1; i < 36; ++i) EXPECT_EQ(in.Read<double>(), 0.0);
      for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(in.Read<double>(), d["centre"][i].get<double>(), 1e-9);
      const double qx = in.Read<double>(), qy = in.Read<double>(), qz = in.Read<double>(),
                   qw = in.Read<double>();
      EXPECT_NEAR(qx, d["quaternion"][0].get<double>(), 1e-9);
      EXPECT_NEAR(qy, d["quaternion"][1].get<double>(), 1e-9);
      EXPECT_NEAR(
          std::abs(qz * d["quaternion"][2].get<double>() + qw * d["quaternion"][3].get<double>()),
          1,
          1e-9);
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(in.Read<double>(), d["size"][i].get<double>(), 1e-9);
      EXPECT_EQ(in.String("id"), std::to_string(index++));  // unique in the message
      ++boxes;
    }
    EXPECT_LT(in.remaining(), 4u);
    ++scan;
  });
  EXPECT_EQ(scan, 8u);
  EXPECT_GT(boxes, 0u);
  EXPECT_EQ(out_topics["/furnidet/detections"], 8);
  for (const auto& [topic, count] : per_topic) EXPECT_EQ(out_topics[topic], count) << topic;
  // A rerun replaces the bag folder and keeps one set of detections.
  ASSERT_EQ(Workbench("detect --quiet --model " + Model() + " --bag " + ros2 +
                      " --topic /camera/depth/image_raw --out " + lines2 + " --out-bag " + marked)
                .exit_code,
            0);
  int again = 0;
  ForEachRos2Message(marked,
                     [&](const Ros2Message& m) { again += m.topic == "/furnidet/detections"; });
  EXPECT_EQ(again, 8);
  EXPECT_FALSE(std::filesystem::exists(marked + ".partial-" + std::to_string(getpid())));
}

// What @mcap/core (Foxglove's reader, tools/mcap_check/check.cjs) finds in an
// MCAP file, as JSON; null when node or the npm modules are not installed
// (`npm ci --prefix tools/mcap_check`, or FURN_MCAP_NODE_MODULES).
std::optional<nlohmann::json> McapCoreRead(const std::string& file) {
  const std::string tools = std::string(FURN_SOURCE_DIR) + "/tools/mcap_check";
  const char* env = std::getenv("FURN_MCAP_NODE_MODULES");
  const std::string modules = env != nullptr ? env : tools + "/node_modules";
  if (testing::RunCommand("node --version").exit_code != 0 ||
      !std::filesystem::exists(modules + "/@mcap/core")) {
    std::cout << "[ SKIPPED  ] the @mcap/core check: no node or no " << modules
              << "/@mcap/core (npm ci --prefix tools/mcap_check)\n";
    return std::nullopt;
  }
  const testing::CommandResult r = testing::RunCommand("NODE_PATH=" + modules + " node " + tools +
                                                       "/check.cjs " + file + " 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  if (r.exit_code != 0) return std::nullopt;
  return nlohmann::json::parse(r.output);
}

// A Jazzy-style MCAP bag (what `ros2 bag record` writes since Iron) reads
// as its SQLite twin: the same scans and detections; `--out-bag` of an MCAP
// input is an MCAP bag, in the input's chunk compression, that @mcap/core
// reads (when node is present) with the messages' schemas and QoS.
TEST_F(RosbagTest, McapBagsDetectAsTheirSqliteTwins) {
  const std::string sqlite = *dir_ + "/twin_sqlite", mcap = *dir_ + "/twin_mcap";
  ASSERT_EQ(Workbench("dataset export " + Db() + " --format rosbag --out " + sqlite).exit_code, 0);
  const testing::CommandResult exported =
      Workbench("dataset export " + Db() + " --format rosbag --storage mcap --out " + mcap);
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  ASSERT_TRUE(std::filesystem::exists(mcap + "/twin_mcap_0.mcap"));
  EXPECT_NE(ReadFileBytes(mcap + "/metadata.yaml").find("storage_identifier: mcap"),
            std::string::npos);
  BagScanOptions options;
  options.topic = "/camera/depth/image_raw";
  std::vector<BagScan> one, two;
  options.bag_path = sqlite;
  ForEachScanInBag(options, [&](const BagScan& scan) { one.push_back(scan); });
  options.bag_path = mcap + "/twin_mcap_0.mcap";  // the file alone reads too
  ForEachScanInBag(options, [&](const BagScan& scan) { two.push_back(scan); });
  ASSERT_EQ(one.size(), 8u);
  ASSERT_EQ(two.size(), one.size());
  for (size_t k = 0; k < one.size(); ++k) {
    EXPECT_EQ(two[k].stamp, one[k].stamp);
    EXPECT_TRUE(two[k].pose_from_tf);
    ASSERT_EQ(two[k].loaded.input.points.size(), one[k].loaded.input.points.size());
    EXPECT_EQ(0,
              std::memcmp(two[k].loaded.input.points.data(),
                          one[k].loaded.input.points.data(),
                          one[k].loaded.input.points.size() * sizeof(Eigen::Vector3f)));
  }
  const std::string lines1 = *dir_ + "/twin1.jsonl", lines2 = *dir_ + "/twin2.jsonl";
  const std::string marked = *dir_ + "/twin_marked";
  for (const auto& [bag, out, extra] : {std::tuple{sqlite, lines1, std::string()},
                                        std::tuple{mcap, lines2, " --out-bag " + marked}}) {
    const testing::CommandResult r =
        Workbench("detect --quiet --model " + Model() + " --bag " + bag +
                  " --topic /camera/depth/image_raw --out " + out + extra);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  const std::vector<nlohmann::json> a = JsonLines(lines1), b = JsonLines(lines2);
  ASSERT_EQ(a.size(), 8u);
  ASSERT_EQ(b.size(), a.size());
  size_t detections = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    ExpectSameDetections(a[k]["detections"], b[k]["detections"]);
    detections += a[k]["detections"].size();
  }
  EXPECT_GT(detections, 0u);
  // The marked bag: MCAP like its input, zstd chunks like its input, every
  // input message and the detections, each topic with a schema and its QoS.
  const std::string file = marked + "/twin_marked_0.mcap";
  ASSERT_TRUE(std::filesystem::exists(file));
  McapReader out(file);
  EXPECT_EQ(out.compression(), McapCompression::kZstd);
  std::map<std::string, const McapChannel*> channels;
  for (const auto& [id, channel] : out.channels()) channels[channel.topic] = &channel;
  ASSERT_TRUE(channels.count("/furnidet/detections_3d"));
  const McapSchema& boxes = out.schemas().at(channels["/furnidet/detections_3d"]->schema_id);
  EXPECT_EQ(boxes.name, "vision_msgs/msg/Detection3DArray");
  EXPECT_EQ(boxes.encoding, "ros2msg");
  EXPECT_NE(boxes.data.find("MSG: vision_msgs/Detection3D\n"), std::string::npos);
  EXPECT_NE(boxes.data.find("MSG: geometry_msgs/PoseWithCovariance\n"), std::string::npos);
  EXPECT_NE(channels["/tf"]->metadata.at("offered_qos_profiles").find("durability: 2"),
            std::string::npos);
  std::set<uint16_t> all;
  for (const auto& [id, channel] : out.channels()) all.insert(id);
  EXPECT_EQ(out.Count(all), 1 + 8 * 5 + 2 * 8);  // /tf_static once
  if (const std::optional<nlohmann::json> seen = McapCoreRead(file)) {
    EXPECT_EQ((*seen)["profile"], "ros2");
    EXPECT_EQ((*seen)["counts"]["/furnidet/detections_3d"], 8);
    EXPECT_EQ((*seen)["counts"]["/camera/depth/image_raw"], 8);
    EXPECT_EQ((*seen)["statistics_messages"], 1 + 8 * 5 + 2 * 8);
    EXPECT_EQ((*seen)["streamed"]["messages"], 1 + 8 * 5 + 2 * 8);
    EXPECT_TRUE((*seen)["ordered"].get<bool>());
    for (const nlohmann::json& channel : (*seen)["channels"]) {
      EXPECT_EQ(channel["encoding"], "cdr");
      EXPECT_EQ(channel["schema_encoding"], "ros2msg");
      EXPECT_GT(channel["schema_bytes"].get<int>(), 0) << channel["topic"];
    }
  }
}

// The committed Jazzy-style fixture (tests/data/mcap_jazzy/: container by
// @mcap/core's writer with lz4 chunks, PointCloud2 messages encoded in
// JavaScript; see its README) detects as its SQLite twin made here from the
// same messages, with the camera's pose from its TF.
TEST_F(RosbagTest, AnMcapBagWrittenByAnotherWriterReadsAsItsSqliteTwin) {
  const std::string fixture = std::string(FURN_SOURCE_DIR) + "/tests/data/mcap_jazzy/frames";
  const std::string twin = *dir_ + "/fixture_twin";
  {
    Ros2BagWriter writer(twin);
    ForEachRos2Message(fixture, [&](const Ros2Message& m) { writer.Write(m); });
    EXPECT_EQ(writer.Finish(), 1 + 2 * 2);
  }
  EXPECT_EQ(McapReader::FirstChunkCompression(fixture + "/frames_0.mcap"), McapCompression::kLz4);
  const std::string lines1 = *dir_ + "/fixture1.jsonl", lines2 = *dir_ + "/fixture2.jsonl";
  for (const auto& [bag, out] : {std::pair{fixture, lines1}, std::pair{twin, lines2}}) {
    const testing::CommandResult r = Workbench("detect --quiet --model " + Model() + " --bag " +
                                               bag + " --topic /camera/depth/points --out " + out);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  const std::vector<nlohmann::json> a = JsonLines(lines1), b = JsonLines(lines2);
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(b.size(), a.size());
  size_t detections = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k]["pose_source"], "tf: world <- camera_depth_optical_frame");
    EXPECT_EQ(a[k]["boxes_frame_id"], "world");
    EXPECT_EQ(a[k]["points"], b[k]["points"]);
    ExpectSameDetections(a[k]["detections"], b[k]["detections"]);
    detections += a[k]["detections"].size();
  }
  EXPECT_GT(detections, 0u);  // the sparse clouds still show the room's table
}

TEST_F(RosbagTest, PointCloud2WithPaddingAndNoTfFindsTheFloor) {
  // Organised PointCloud2 of one frame, x y z with an rgb field between y and z.
  DatasetDb dataset(Db(), DatasetDb::Mode::kReadOnly);
  const FrameRecord frame = dataset.ReadRoom(dataset.RoomIds().back(), true).frames.front();
  const DetectionInput input = DetectionInputOf(frame, "frame");
  sensor_msgs::PointCloud2 cloud;
  cloud.header.frame_id = "kinect";
  cloud.header.stamp = ros::Time(5, 0);
  cloud.height = frame.height;
  cloud.width = frame.width;
  const char* names[4] = {"x", "y", "rgb", "z"};
  for (int k = 0; k < 4; ++k) {
    sensor_msgs::PointField field;
    field.name = names[k];
    field.offset = 4 * k;
    field.datatype = sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    cloud.fields.push_back(field);
  }
  cloud.point_step = 16;
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.data.resize(cloud.row_step * cloud.height);
  for (size_t i = 0; i < input.points.size(); ++i) {
    const float xyz[4] = {input.points[i].x(), input.points[i].y(), 0.5f, input.points[i].z()};
    std::memcpy(&cloud.data[16 * i], xyz, 16);
  }
  const std::string path = *dir_ + "/cloud.bag";
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.write("/points", ros::Time(5, 0), cloud);
    // The same cloud with a world pose from TF, under another frame id.
    tf2_msgs::TFMessage tf;
    geometry_msgs::TransformStamped t;
    t.header.frame_id = "world";
    t.header.stamp = ros::Time(6, 0);
    t.child_frame_id = "kinect_posed";
    const Eigen::Quaterniond q(frame.world_from_camera.linear());
    t.transform.rotation.w = q.w();
    t.transform.rotation.x = q.x();
    t.transform.rotation.y = q.y();
    t.transform.rotation.z = q.z();
    t.transform.translation.x = frame.world_from_camera.translation().x();
    t.transform.translation.y = frame.world_from_camera.translation().y();
    t.transform.translation.z = frame.world_from_camera.translation().z();
    tf.transforms.push_back(t);
    bag.write("/tf_static", ros::Time(6, 0), tf);
    cloud.header.frame_id = "kinect_posed";
    cloud.header.stamp = ros::Time(6, 0);
    bag.write("/points", ros::Time(6, 0), cloud);
  }
  const std::string out = *dir_ + "/cloud.jsonl";
  const testing::CommandResult r = Workbench("detect --quiet --model " + Model() + " --bag " +
                                             path + " --topic /points --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::vector<nlohmann::json> lines = JsonLines(out);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0]["pose_source"], "floor estimated");
  EXPECT_EQ(lines[0]["frame_id"], "kinect");
  EXPECT_EQ(lines[1]["pose_source"], "tf: world <- kinect_posed");
  ExpectSameDetections(lines[1]["detections"], DetectFrame(frame.id));
  // The floor found in the first: the camera at the frame's height.
  const std::vector<std::vector<double>> pose = lines[0]["world_from_camera"];  // rows
  EXPECT_NEAR(pose[2][3], frame.world_from_camera.translation().z(), 0.03);
}

// A cloud in camera_link (REP 103 body axes: x forward, z up) is turned to
// optical axes when TF places it, giving the detections of the same points
// in the optical frame; without TF the bag is refused with one line.
TEST_F(RosbagTest, ACloudInABodyFrameIsTurnedByTfOrRefused) {
  DatasetDb dataset(Db(), DatasetDb::Mode::kReadOnly);
  const FrameRecord frame = dataset.ReadRoom(dataset.RoomIds().back(), true).frames.front();
  const DetectionInput input = DetectionInputOf(frame, "frame");
  const Eigen::Matrix3f body_from_optical = BodyFromOptical().toRotationMatrix().cast<float>();
  RosPointCloud2 cloud;
  cloud.header = {6.0, "camera_link", 0};
  cloud.height = static_cast<uint32_t>(frame.height);
  cloud.width = static_cast<uint32_t>(frame.width);
  for (uint32_t k = 0; k < 3; ++k) cloud.fields.push_back({std::string(1, "xyz"[k]), 4 * k, 7, 1});
  cloud.point_step = 12;
  cloud.row_step = 12 * cloud.width;
  cloud.data.resize(size_t{cloud.row_step} * cloud.height);
  for (size_t i = 0; i < input.points.size(); ++i) {
    const Eigen::Vector3f body = body_from_optical * input.points[i];
    std::memcpy(&cloud.data[12 * i], body.data(), 12);
  }
  RosTransform placed;
  placed.header = {6.0, "world", 0};
  placed.child_frame_id = "camera_link";
  const Eigen::Isometry3d world_from_body =
      frame.world_from_camera * Eigen::Isometry3d(BodyFromOptical().conjugate());
  placed.translation = world_from_body.translation();
  placed.rotation = Eigen::Quaterniond(world_from_body.linear());
  const std::string with_tf = *dir_ + "/body_tf", without = *dir_ + "/body_no_tf";
  for (const std::string& bag : {with_tf, without}) {
    Ros2BagWriter writer(bag, Ros2Storage::kMcap);
    if (bag == with_tf)
      writer.Write("/tf_static", kRos2TfMessage, 6'000'000'000, EncodeTfMessage({placed}));
    writer.Write("/points", kRos2PointCloud2, 6'000'000'000, EncodePointCloud2(cloud));
    writer.Finish();
  }
  const std::string out = *dir_ + "/body.jsonl";
  const testing::CommandResult r = Workbench("detect --quiet --model " + Model() + " --bag " +
                                             with_tf + " --topic /points --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::vector<nlohmann::json> lines = JsonLines(out);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0]["pose_source"],
            "tf: world <- camera_link (a body frame, turned to optical axes)");
  EXPECT_EQ(lines[0]["boxes_frame_id"], "world");
  ExpectSameDetections(lines[0]["detections"], DetectFrame(frame.id));
  const testing::CommandResult refused =
      Workbench("detect --quiet --model " + Model() + " --bag " + without + " --topic /points");
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("PointCloud2 in 'camera_link', a REP 103 body frame (x forward, "
                                "z up), and the bag has no /tf to place it"),
            std::string::npos)
      << refused.output;
  EXPECT_EQ(std::count(refused.output.begin(), refused.output.end(), '\n'), 1) << refused.output;
  EXPECT_TRUE(IsBodyFrame("base_link"));
  EXPECT_TRUE(IsBodyFrame("odom"));
  EXPECT_FALSE(IsBodyFrame("camera_depth_optical_frame"));
  EXPECT_FALSE(IsBodyFrame("kinect"));  // unknown names stay optical, as drivers publish clouds
}

TEST_F(RosbagTest, BadBagsAndTopicsGetOneClearLine) {
  const std::string junk = *dir_ + "/junk.bag";
  testing::WriteText(junk, "#ROSBAG V2.0\nnot really");
  const std::string base = "detect --model " + Model() + " ";
  const struct {
    std::string arguments, message;
  } cases[] = {
      {"--bag " + junk + " --topic /x", "junk.bag: not a readable ROS 1 bag"},
      {"--bag " + *dir_ + "/missing.bag --topic /x", "missing.bag"},
      {"--bag " + Bag(), "--bag needs --topic"},
      {"--bag " + Bag() + " --topic /nothing", "no messages on topic /nothing"},
      {"--bag " + Bag() + " --topic /tf", "topic /tf is tf2_msgs/TFMessage; it must be"},
      {"--bag " + Bag() + " --topic /camera/depth/image_raw --camera-info /none",
       "no sensor_msgs/CameraInfo on /none"},
      {"--bag " + Bag() + " --topic /camera/depth/image_raw --camera-info /camera/depth/ids",
       "no sensor_msgs/CameraInfo on /camera/depth/ids"},
      {"--bag " + Bag() + " --topic /camera/depth/image_raw --out-bag " + Bag(),
       "must not be the input bag"},
      {"--cloud x.pcd --topic /points", "--topic, --camera-info and --out-bag apply to --bag"},
      {"--bag " + Bag() + " --topic /points --db " + Db(), "--bag takes no other scans"},
  };
  for (const auto& c : cases) {
    const testing::CommandResult r = Workbench(base + c.arguments);
    EXPECT_NE(r.exit_code, 0) << c.arguments;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << c.arguments << "\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  const testing::CommandResult split = Workbench(
      "dataset export " + Db() + " --format rosbag --split nope --out " + *dir_ + "/x.bag");
  EXPECT_NE(split.exit_code, 0);
  EXPECT_NE(split.output.find("--split 'nope' must be train, val, test or all"), std::string::npos)
      << split.output;
  EXPECT_FALSE(std::filesystem::exists(*dir_ + "/x.bag"));
  EXPECT_FALSE(std::filesystem::exists(*dir_ + "/x.bag.partial"));
}

// The hostile bags of issue 29 (tests/data/crashers/bags_meshes): each
// ended in a crash, gigabytes or the library's own text; now one line, a
// non-zero exit, within 2 GB and 10 s (ulimit and the clock).
TEST_F(RosbagTest, HostileBagsAreOneLineWithinMemoryAndTime) {
  const std::string dir = FURN_SOURCE_DIR "/tests/data/crashers/bags_meshes/";
  const struct {
    const char* bag;
    const char* topic;
    const char* message;
  } cases[] = {
      {"index_offset_past_chunk.bag", "/camera/depth/image_raw", "past its chunk"},
      {"image_data_len_4G.bag", "/camera/depth/image_raw", "data claims"},
      {"tf_count_16M.bag", "/camera/depth/image_raw", "transforms claims"},
      {"bag_messy_seed3_run35.bag", "/camera/depth/points", "bag_messy_seed3_run35.bag"},
      {"index_pos_mid_record.bag", "/camera/depth/image_raw", "is not the start of a record"},
  };
  for (const auto& c : cases) {
    const auto start = std::chrono::steady_clock::now();
    const testing::CommandResult r = testing::RunCommand(
        "ulimit -v 2000000; " + std::string(FURN_WORKBENCH_BINARY) + " detect --model " + Model() +
        " --bag " + dir + c.bag + " --topic " + c.topic + " --out " + *dir_ +
        "/o.jsonl --out-bag " + *dir_ + "/out.bag");
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_GT(r.exit_code, 0) << c.bag;
    EXPECT_LT(r.exit_code, 128) << c.bag << " (a signal)";
    EXPECT_NE(r.output.find(c.message), std::string::npos) << c.bag << "\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << c.bag << "\n" << r.output;
    EXPECT_LT(seconds, 10) << c.bag;
    EXPECT_FALSE(std::filesystem::exists(*dir_ + "/out.bag")) << c.bag;
    EXPECT_FALSE(std::filesystem::exists(*dir_ + "/out.bag.partial")) << c.bag;
  }
}

// A bag our exporter wrote passes the structure check, and every message of
// it the field check; cut short, it fails with the record named.
// A /tf transform that is not finite or not a unit quaternion, and a scan
// stamped beyond ROS time with --out-bag: one line naming the rule (issue 29).
TEST_F(RosbagTest, BadTransformsAndStampsAreNamed) {
  const std::string tf_bag = *dir_ + "/bad_tf.bag";
  {
    rosbag::Bag bag(tf_bag, rosbag::bagmode::Write);
    tf2_msgs::TFMessage tf;
    geometry_msgs::TransformStamped t;
    t.header.stamp = ros::Time(1, 0);
    t.header.frame_id = "world";
    t.child_frame_id = "camera";
    t.transform.rotation.w = 1e200;
    tf.transforms.push_back(t);
    bag.write("/tf", ros::Time(1, 0), tf);
  }
  const testing::CommandResult tf =
      Workbench("detect --model " + Model() + " --bag " + tf_bag + " --topic /x");
  EXPECT_EQ(tf.exit_code, 1);
  EXPECT_NE(tf.output.find("transform world -> camera at 1.000"), std::string::npos) << tf.output;
  EXPECT_NE(tf.output.find("unit quaternion"), std::string::npos) << tf.output;

  // The exported bag's first image and camera info, stamped 2^32 - 1 s.
  const std::string late = *dir_ + "/late.bag";
  {
    rosbag::Bag in(Bag(), rosbag::bagmode::Read);
    rosbag::Bag out(late, rosbag::bagmode::Write);
    rosbag::View view(in,
                      rosbag::TopicQuery(std::vector<std::string>{"/camera/depth/image_raw",
                                                                  "/camera/depth/camera_info"}));
    bool image_written = false, info_written = false;
    for (const rosbag::MessageInstance& m : view) {
      if (auto image = m.instantiate<sensor_msgs::Image>()) {
        if (image_written) continue;
        image->header.stamp = ros::Time(4294967295u, 0);
        out.write(m.getTopic(), m.getTime(), *image);
        image_written = true;
      } else if (auto info = m.instantiate<sensor_msgs::CameraInfo>()) {
        out.write(m.getTopic(), m.getTime(), *info);
        info_written = true;
      }
      if (image_written && info_written) break;
    }
  }
  const testing::CommandResult stamp = Workbench(
      "detect --quiet --model " + Model() + " --bag " + late +
      " --topic /camera/depth/image_raw --tf-world '' --out-bag " + *dir_ + "/late_out.bag");
  EXPECT_EQ(stamp.exit_code, 1) << stamp.output;
  EXPECT_NE(stamp.output.find("lies outside ROS time"), std::string::npos) << stamp.output;
  EXPECT_EQ(std::count(stamp.output.begin(), stamp.output.end(), '\n'), 1) << stamp.output;
  EXPECT_FALSE(std::filesystem::exists(*dir_ + "/late_out.bag"));
}

TEST_F(RosbagTest, TheBoundedReaderAcceptsOurBagsAndRefusesACutOne) {
  EXPECT_NO_THROW(CheckBagFile(Bag()));
  const std::string bytes = ReadFileBytes(Bag());
  const std::string cut = *dir_ + "/cut.bag";
  testing::WriteText(cut, bytes.substr(0, bytes.size() / 2));
  EXPECT_NE(testing::ErrorOf([&] {
              CheckBagFile(cut);
            }).find("cut.bag: not a readable ROS 1 bag: record at byte"),
            std::string::npos);
  testing::WriteText(cut, "#ROSBAG V1.2\n");
  EXPECT_NE(testing::ErrorOf([&] { CheckBagFile(cut); }).find("not a ROS 1 bag of format 2.0"),
            std::string::npos);
}

}  // namespace
}  // namespace furn
