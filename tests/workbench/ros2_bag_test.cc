// ROS 2 bags without ROS: CDR laid out as the spec says (alignment from the
// end of the encapsulation header), messages that decode as they were
// encoded, a bag folder written and read back, and hostile bags and
// messages refused with one line naming the bag, within their own size.
// The comparison with the ROS 1 path is in rosbag_test (ROS builds only).
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/file_util.h"
#include "db/sqlite.h"
#include "tests/test_util.h"
#include "workbench/formats/cdr.h"
#include "workbench/formats/ros2_bag.h"
#include "workbench/formats/ros2_messages.h"
#include "workbench/formats/ros_common.h"

namespace furn {
namespace {

namespace fs = std::filesystem;

TEST(Cdr, AlignsEachValueToItsSizeFromTheEndOfTheHeader) {
  CdrWriter out;
  out.Write<int32_t>(7);
  out.Write<uint32_t>(500);
  out.String("ab");
  out.Write<uint8_t>(1);
  out.Write<double>(0.5);
  const std::vector<uint8_t> bytes = out.Take();
  // header 4 | sec 4 | nanosec 4 | length 4 | "ab\0" 3 | uint8 1 | double at 16 after the header.
  ASSERT_EQ(bytes.size(), 28u);
  EXPECT_EQ(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 4),
            (std::vector<uint8_t>{0, 1, 0, 0}));
  EXPECT_EQ(bytes[12], 3);  // the string's length counts its NUL
  EXPECT_EQ(bytes[16], 'a');
  EXPECT_EQ(bytes[18], 0);
  EXPECT_EQ(bytes[19], 1);
  double half;
  std::memcpy(&half, &bytes[20], 8);
  EXPECT_EQ(half, 0.5);
  CdrReader in(bytes.data(), bytes.size(), "test");
  EXPECT_EQ(in.Read<int32_t>(), 7);
  EXPECT_EQ(in.Read<uint32_t>(), 500u);
  EXPECT_EQ(in.String("s"), "ab");
  EXPECT_EQ(in.Read<uint8_t>(), 1);
  EXPECT_EQ(in.Read<double>(), 0.5);
  EXPECT_EQ(in.remaining(), 0u);
}

RosImage SomeImage() {
  RosImage image;
  image.header = {12.25, "camera_depth_optical_frame", 0};
  image.width = 3;
  image.height = 2;
  image.encoding = "16UC1";
  image.step = 6;
  image.data = {1, 0, 2, 0, 3, 0, 4, 0, 5, 0, 6, 0};
  return image;
}

TEST(Ros2Messages, DecodeAsTheyWereEncoded) {
  const RosImage image = SomeImage();
  const RosImage back = DecodeImage(EncodeImage(image), "image");
  EXPECT_EQ(back.header.frame_id, image.header.frame_id);
  EXPECT_NEAR(back.header.stamp, 12.25, 1e-9);
  EXPECT_EQ(back.width, 3u);
  EXPECT_EQ(back.encoding, "16UC1");
  EXPECT_EQ(back.data, image.data);

  RosCameraInfo info;
  info.header = image.header;
  info.width = 640;
  info.height = 480;
  info.k = {525, 0, 319.5, 0, 525, 239.5, 0, 0, 1};
  const RosCameraInfo info_back = DecodeCameraInfo(EncodeCameraInfo(info), "info");
  EXPECT_EQ(info_back.k, info.k);
  EXPECT_EQ(info_back.width, 640u);
  EXPECT_EQ(info_back.d.size(), 5u);

  RosPointCloud2 cloud;
  cloud.width = 2;
  cloud.height = 1;
  cloud.fields = {{"x", 0, 7, 1}, {"y", 4, 7, 1}, {"z", 8, 7, 1}};
  cloud.point_step = 12;
  cloud.row_step = 24;
  cloud.data.assign(24, 0);
  cloud.is_dense = true;
  const RosPointCloud2 cloud_back = DecodePointCloud2(EncodePointCloud2(cloud), "cloud");
  ASSERT_EQ(cloud_back.fields.size(), 3u);
  EXPECT_EQ(cloud_back.fields[2].name, "z");
  EXPECT_EQ(cloud_back.fields[2].offset, 8u);
  EXPECT_TRUE(cloud_back.is_dense);

  RosTransform t;
  t.header = {3.5, "world", 0};
  t.child_frame_id = "camera";
  t.translation = Eigen::Vector3d(1, 2, 3);
  t.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  const std::vector<RosTransform> tf = DecodeTfMessage(EncodeTfMessage({t, t}), "tf");
  ASSERT_EQ(tf.size(), 2u);
  EXPECT_EQ(tf[1].child_frame_id, "camera");
  EXPECT_TRUE(tf[1].translation.isApprox(t.translation));
  EXPECT_TRUE(tf[1].rotation.isApprox(t.rotation));
}

// A message decoder refuses, with one line naming the message, what does
// not fit: cut anywhere, lengths claiming more than there is, wrong types.
TEST(Ros2Messages, DamagedMessagesAreRefusedByName) {
  const std::vector<uint8_t> good = EncodeImage(SomeImage());
  for (size_t cut = 0; cut < good.size() - 3; ++cut) {
    const std::vector<uint8_t> bad(good.begin(), good.begin() + cut);
    EXPECT_THROW(DecodeImage(bad, "bag.db3 /depth at 1.0"), InputError) << cut;
  }
  std::vector<uint8_t> huge = good;
  const uint32_t claim = 0xFFFFFFF0u;
  std::memcpy(&huge[good.size() - 12 - 4], &claim, 4);  // the data length
  try {
    DecodeImage(huge, "bag.db3 /depth at 1.0");
    ADD_FAILURE() << "a 4 GB claim was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bag.db3 /depth at 1.0: data claims 4294967280"),
              std::string::npos)
        << e.what();
  }
  std::vector<uint8_t> big_endian = good;
  big_endian[1] = 0;
  EXPECT_THROW(DecodeImage(big_endian, "x"), InputError);
  // A TFMessage is not an image: its bytes are refused, not misread.
  RosTransform t;
  t.child_frame_id = "c";
  EXPECT_THROW(DecodeImage(EncodeTfMessage({t}), "x"), InputError);
  EXPECT_THROW(DecodeTfMessage(good, "x"), InputError);
}

// Random damage to every decoder: an InputError or a message, never a crash
// or an allocation beyond the message (run under ASan in that build).
TEST(Ros2Messages, FuzzedMessagesNeverCrash) {
  RosCameraInfo info;
  info.width = info.height = 4;
  RosTransform t;
  t.child_frame_id = "camera";
  RosPointCloud2 cloud;
  cloud.fields = {{"x", 0, 7, 1}};
  const std::vector<std::vector<uint8_t>> seeds = {EncodeImage(SomeImage()),
                                                   EncodeCameraInfo(info),
                                                   EncodeTfMessage({t}),
                                                   EncodePointCloud2(cloud)};
  std::mt19937 random(5);
  int refused = 0, decoded = 0;
  for (int round = 0; round < 20000; ++round) {
    std::vector<uint8_t> bytes = seeds[round % seeds.size()];
    const int flips = 1 + static_cast<int>(random() % 4);
    for (int f = 0; f < flips; ++f) bytes[random() % bytes.size()] = static_cast<uint8_t>(random());
    if (random() % 4 == 0) bytes.resize(random() % bytes.size());
    try {
      switch (round % 4) {
        case 0:
          DecodeImage(bytes, "fuzz");
          break;
        case 1:
          DecodeCameraInfo(bytes, "fuzz");
          break;
        case 2:
          DecodeTfMessage(bytes, "fuzz");
          break;
        default:
          DecodePointCloud2(bytes, "fuzz");
          break;
      }
      ++decoded;
    } catch (const InputError&) {
      ++refused;
    }
  }
  EXPECT_GT(refused, 1000);
  EXPECT_GT(decoded, 100);
}

class Ros2BagTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = testing::ScratchDir(); }
  // A bag of `frames` images with CameraInfo and a TF pose.
  std::string WriteBag(const std::string& name, int frames) {
    const std::string path = dir_ + "/" + name;
    Ros2BagWriter bag(path);
    RosCameraInfo info;
    info.header = {1, "cam", 0};
    info.width = 3;
    info.height = 2;
    info.k = {2, 0, 1, 0, 2, 1, 0, 0, 1};
    RosTransform pose;
    pose.header = {1, "world", 0};
    pose.child_frame_id = "cam";
    pose.translation = Eigen::Vector3d(0, 0, 1.2);
    bag.Write("/tf_static", kRos2TfMessage, 900000000, EncodeTfMessage({pose}));
    for (int k = 0; k < frames; ++k) {
      RosImage image = SomeImage();
      image.header = {1 + 0.1 * k, "cam", 0};
      const int64_t time = 1000000000 + k * int64_t{100000000};
      bag.Write("/cam/camera_info", kRos2CameraInfo, time, EncodeCameraInfo(info));
      bag.Write("/cam/image", kRos2Image, time, EncodeImage(image));
    }
    EXPECT_EQ(bag.Finish(), 1 + 2 * frames);
    return path;
  }
  std::string dir_;
};

TEST_F(Ros2BagTest, AFolderWrittenHereReadsBackWithMetadata) {
  const std::string bag = WriteBag("run", 3);
  const std::string metadata = ReadFileBytes(bag + "/metadata.yaml");
  for (const char* expected : {"storage_identifier: sqlite3",
                               "message_count: 7",
                               "name: /cam/image",
                               "type: sensor_msgs/msg/Image",
                               "run_0.db3",
                               "nanoseconds_since_epoch: 900000000"})
    EXPECT_NE(metadata.find(expected), std::string::npos) << expected << "\n" << metadata;
  BagScanOptions options;
  options.bag_path = bag;
  options.topic = "/cam/image";
  std::vector<BagScan> scans;
  EXPECT_EQ(ForEachScanInBag(options, [&](const BagScan& s) { scans.push_back(s); }), 3);
  ASSERT_EQ(scans.size(), 3u);
  EXPECT_TRUE(scans[2].pose_from_tf);
  EXPECT_NEAR(scans[2].stamp, 1.2, 1e-9);
  EXPECT_EQ(scans[2].total, 3);
  EXPECT_NEAR(scans[0].loaded.input.world_from_camera->translation().z(), 1.2, 1e-12);
  EXPECT_EQ(scans[0].loaded.input.points.size(), 6u);
  // The .db3 alone reads as the folder does.
  options.bag_path = bag + "/run_0.db3";
  EXPECT_EQ(ForEachScanInBag(options, [](const BagScan&) {}), 3);
  // Written again over itself: replaced, one bag's messages.
  WriteBag("run", 2);
  int messages = 0;
  ForEachRos2Message(bag, [&](const Ros2Message&) { ++messages; });
  EXPECT_EQ(messages, 5);
}

TEST_F(Ros2BagTest, AWriterNeverReplacesWhatIsNotABagOrLeavesAHalfOne) {
  const std::string precious = dir_ + "/precious";
  fs::create_directories(precious);
  testing::WriteText(precious + "/notes.txt", "mine");
  EXPECT_THROW(Ros2BagWriter{precious}, InputError);
  EXPECT_TRUE(fs::exists(precious + "/notes.txt"));
  {
    Ros2BagWriter unfinished(dir_ + "/half");
    unfinished.Write("/x", kRos2Image, 1, EncodeImage(SomeImage()));
  }  // destroyed without Finish
  EXPECT_FALSE(fs::exists(dir_ + "/half"));
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_))
    EXPECT_EQ(entry.path().filename().string().find("half"), std::string::npos) << entry.path();
}

// Each hostile bag: one InputError naming the bag and the rule.
TEST_F(Ros2BagTest, HostileBagsAreRefusedByName) {
  const std::string bag = WriteBag("good", 2);
  const std::string db3 = bag + "/good_0.db3";
  BagScanOptions options;
  options.topic = "/cam/image";
  auto expect_refused = [&](const std::string& path, const std::string& message) {
    options.bag_path = path;
    try {
      ForEachScanInBag(options, [](const BagScan&) {});
      ADD_FAILURE() << path << ": accepted";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(message), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  };
  const std::string junk = dir_ + "/junk.db3";
  testing::WriteText(junk, "SQLite format 3 but not really");
  expect_refused(junk, "junk.db3");
  fs::create_directories(dir_ + "/empty");
  expect_refused(dir_ + "/empty", "no .db3 file");
  fs::create_directories(dir_ + "/mcap");
  testing::WriteText(dir_ + "/mcap/x_0.mcap", "");
  expect_refused(dir_ + "/mcap", "MCAP or compressed storage");
  options.topic = "/nothing";
  expect_refused(bag, "no topic /nothing");
  options.topic = "/tf_static";
  expect_refused(bag, "tf2_msgs/msg/TFMessage; it must be");
  options.topic = "/cam/image";

  auto damaged = [&](const std::string& name, const std::string& sql) {
    const std::string copy = dir_ + "/" + name + ".db3";
    fs::copy_file(db3, copy, fs::copy_options::overwrite_existing);
    Database db(copy);
    db.Execute("PRAGMA journal_mode = DELETE;" + sql);
    return copy;
  };
  expect_refused(damaged("no_messages", "DROP TABLE messages"), "no 'messages' table");
  expect_refused(damaged("view",
                         "ALTER TABLE topics RENAME TO t2; CREATE VIEW topics AS "
                         "SELECT * FROM t2"),
                 "no 'topics' table");
  expect_refused(damaged("json", "UPDATE topics SET serialization_format = 'json'"),
                 "serialization 'json' is not cdr");
  expect_refused(damaged("cut",
                         "UPDATE messages SET data = substr(data, 1, 40) WHERE topic_id = "
                         "(SELECT id FROM topics WHERE name = '/cam/image')"),
                 "/cam/image at 1.000");
  expect_refused(damaged("claims",
                         "UPDATE messages SET data = X'00010000FFFFFFFF' WHERE topic_id = "
                         "(SELECT id FROM topics WHERE name = '/tf_static')"),
                 "transforms claims 4294967295 elements");
  expect_refused(damaged("wrong_type",
                         "UPDATE topics SET type = 'sensor_msgs/msg/Image' WHERE name = "
                         "'/cam/camera_info'"),
                 "/cam/camera_info");
}

// Each detection's label says how much of its box is in view when the frame
// cuts it (its centre is then a guess from the part in view).
TEST(DetectionMarkers, LabelsOfBoxesCutByTheFrameSaySo) {
  DetectionResult result;
  Detection whole;
  whole.width = whole.depth = 0.5;
  whole.score = 0.83;
  Detection cut = whole;
  cut.furniture_class = FurnitureClass::kTable;
  cut.x = 2;
  cut.in_view = 0.4;
  result.detections = {whole, cut};
  const std::vector<RosMarker> markers =
      DetectionMarkers(result, TrainedModel{}, RosHeader{}, Eigen::Isometry3d::Identity());
  ASSERT_EQ(markers.size(), 5u);  // DELETEALL, then a box and a label each
  EXPECT_EQ(markers[2].text, "chair 0.83");
  EXPECT_EQ(markers[4].text, "table 0.83 (40% in view)");
  EXPECT_EQ(markers[4].ns, "furnidet/labels");
}

}  // namespace
}  // namespace furn
