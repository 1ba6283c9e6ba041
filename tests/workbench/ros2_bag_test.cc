// ROS 2 bags without ROS: CDR laid out as the spec says (alignment from the
// end of the encapsulation header), messages that decode as they were
// encoded, a bag folder written and read back, and hostile bags and
// messages refused with one line naming the bag, within their own size.
// The comparison with the ROS 1 path is in rosbag_test (ROS builds only).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "core/util/error.h"
#include "core/util/file_util.h"
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
  // A copy of the .db3 `db3` named `name`.db3 with `sql` run on it.
  std::string Damaged(const std::string& db3, const std::string& name, const std::string& sql) {
    const std::string copy = dir_ + "/" + name + ".db3";
    fs::copy_file(db3, copy, fs::copy_options::overwrite_existing);
    Database db(copy);
    db.Execute("PRAGMA journal_mode = DELETE;" + sql);
    return copy;
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
  expect_refused(dir_ + "/empty", "no .db3 or .mcap file");
  fs::create_directories(dir_ + "/mcap");
  testing::WriteText(dir_ + "/mcap/x_0.mcap", "");
  expect_refused(dir_ + "/mcap", "x_0.mcap: 0 bytes, too short for an MCAP file");
  fs::create_directories(dir_ + "/zstd_file");
  testing::WriteText(dir_ + "/zstd_file/x_0.mcap.zstd", "(zstd)");
  expect_refused(dir_ + "/zstd_file", "compressed storage files are not read here");
  options.topic = "/nothing";
  expect_refused(bag, "no topic /nothing");
  options.topic = "/tf_static";
  expect_refused(bag, "tf2_msgs/msg/TFMessage; it must be");
  options.topic = "/cam/image";

  auto damaged = [&](const std::string& name, const std::string& sql) {
    return Damaged(db3, name, sql);
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

// Issue 68: SQLite is hostile input. A message stored as TEXT (length()
// stops at its first NUL), a data column computed by an expression (built-in
// functions run even with an untrusted schema), a frame too big to detect:
// each refused in one line before it costs memory.
TEST_F(Ros2BagTest, SqliteCannotMakeUpMessagesOrHideTheirSize) {
  const std::string bag = WriteBag("good", 1);
  const std::string db3 = bag + "/good_0.db3";
  BagScanOptions options;
  options.topic = "/cam/image";
  auto refused = [&](const std::string& path) {
    options.bag_path = path;
    try {
      ForEachScanInBag(options, [](const BagScan&) {});
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  auto damaged = [&](const std::string& name, const std::string& sql) {
    return Damaged(db3, name, sql);
  };
  EXPECT_NE(refused(damaged("text", "UPDATE messages SET data = CAST(data AS TEXT)"))
                .find("stored as text; rosbag2 stores messages as BLOB"),
            std::string::npos);
  const std::string generated = damaged(
      "generated",
      "ALTER TABLE messages RENAME TO m0; CREATE TABLE messages(id INTEGER PRIMARY KEY, "
      "topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, raw BLOB, data BLOB GENERATED "
      "ALWAYS AS (raw || zeroblob(300000000)) VIRTUAL); INSERT INTO messages(id, topic_id, "
      "timestamp, raw) SELECT id, topic_id, timestamp, data FROM m0; DROP TABLE m0");
  EXPECT_NE(refused(generated).find("column 'data' of table 'messages' is generated or hidden"),
            std::string::npos)
      << refused(generated);
  EXPECT_NE(refused(damaged("no_id",
                            "ALTER TABLE messages RENAME TO m0; CREATE TABLE messages(topic_id "
                            "INTEGER, timestamp INTEGER, data BLOB); INSERT INTO messages SELECT "
                            "topic_id, timestamp, data FROM m0; DROP TABLE m0"))
                .find("table 'messages' has no column 'id'"),
            std::string::npos);
  fs::create_symlink(dir_ + "/loop", dir_ + "/loop");
  EXPECT_NE(refused(dir_ + "/loop").find("cannot read (Too many levels of symbolic links)"),
            std::string::npos)
      << refused(dir_ + "/loop");
  // Even a plain column cannot hand over a value longer than the cap.
  Database plain(generated);
  plain.TreatAsUntrusted(1000);
  EXPECT_THROW(plain.Execute("SELECT zeroblob(2000)"), DbError);
  // An image of 5000 x 4000 pixels: within 16384 a side, over the frame cap.
  const std::string big = dir_ + "/big";
  {
    Ros2BagWriter writer(big);
    RosCameraInfo info;
    info.header = {1, "cam", 0};
    info.width = 5000;
    info.height = 4000;
    info.k = {2, 0, 1, 0, 2, 1, 0, 0, 1};
    RosImage image = SomeImage();
    image.width = 5000;
    image.height = 4000;
    writer.Write("/cam/camera_info", kRos2CameraInfo, 1000000000, EncodeCameraInfo(info));
    writer.Write("/cam/image", kRos2Image, 1000000000, EncodeImage(image));
    writer.Finish();
  }
  EXPECT_NE(refused(big).find("at most 16777216 pixels"), std::string::npos) << refused(big);
  // Compressed messages (metadata.yaml's compression_mode) are named as such.
  const std::string metadata = bag + "/metadata.yaml";
  std::string yaml = ReadFileBytes(metadata);
  const std::string plain_mode = "compression_mode: \"\"";
  ASSERT_NE(yaml.find(plain_mode), std::string::npos) << yaml;
  yaml.replace(yaml.find(plain_mode), plain_mode.size(), "compression_mode: message");
  testing::WriteText(metadata, yaml);
  EXPECT_NE(refused(bag).find("compressed storage"), std::string::npos) << refused(bag);
  EXPECT_NE(refused(bag).find("ros2 bag convert"), std::string::npos);
}

// A folder is replaced only when its content is a bag's: subfolders named
// like a bag's files are user files (issue 68 deleted them).
TEST_F(Ros2BagTest, OnlyABagRecognisedByContentIsReplaced) {
  const std::string album = dir_ + "/album";
  fs::create_directories(album + "/photos.db3");
  testing::WriteText(album + "/photos.db3/holiday.jpg", "precious");
  testing::WriteText(album + "/metadata.yaml", "x");
  EXPECT_THROW(Ros2BagWriter{album}, InputError);
  const std::string work = dir_ + "/work";
  fs::create_directories(work + "/metadata.yaml");
  testing::WriteText(work + "/metadata.yaml/thesis.tex", "chapter");
  EXPECT_THROW(Ros2BagWriter{work}, InputError);
  // A bag with a stranger's file beside its own.
  const std::string bag = WriteBag("run", 1);
  testing::WriteText(bag + "/notes.txt", "mine");
  EXPECT_THROW(Ros2BagWriter{bag}, InputError);
  fs::remove(bag + "/notes.txt");
  // A .db3 that is not SQLite is not a bag's either.
  testing::WriteText(bag + "/run_0.db3", "not SQLite");
  EXPECT_THROW(Ros2BagWriter{bag}, InputError);
  EXPECT_EQ(ReadFileBytes(album + "/photos.db3/holiday.jpg"), "precious");
  EXPECT_EQ(ReadFileBytes(work + "/metadata.yaml/thesis.tex"), "chapter");
  // A bag this writer made is replaced.
  fs::remove_all(bag);
  WriteBag("run", 1);
  EXPECT_NO_THROW(WriteBag("run", 2));
}

// A killed writer's <out>.partial-<pid> goes on the next run; one of a live
// process, or holding anything the writer does not make, stays.
TEST_F(Ros2BagTest, ADeadWritersFolderIsCleanedUpOnTheNextRun) {
  const pid_t child = fork();
  if (child == 0) _exit(0);
  ASSERT_GT(child, 0);
  waitpid(child, nullptr, 0);  // a pid nobody runs under now
  const std::string dead = dir_ + "/out.partial-" + std::to_string(child);
  fs::create_directories(dead);
  testing::WriteText(dead + "/out_0.db3", "half");
  testing::WriteText(dead + "/out_0.db3-journal", "half");
  const std::string alive = dir_ + "/out.partial-1";  // init runs
  fs::create_directories(alive);
  testing::WriteText(alive + "/out_0.db3", "half");
  const std::string strange = dir_ + "/out.partial-999999999";
  fs::create_directories(strange);
  testing::WriteText(strange + "/holiday.jpg", "precious");
  WriteBag("out", 1);
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(alive));
  EXPECT_TRUE(fs::exists(strange + "/holiday.jpg"));
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
