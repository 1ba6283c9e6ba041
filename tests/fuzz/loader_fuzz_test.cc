// A seeded mutation fuzzer for every loader a user's file reaches: PCD, PLY,
// depth PNG, .sh3f catalog, class map, model file and dataset DB. Each
// target starts from small valid files, mutates them (bit flips, interesting
// bytes, inserted, deleted and repeated ranges, truncation, and numbers in
// text swapped for hostile ones) and loads each result. A load must succeed
// or throw our InputError/DbError: any other exception fails the test, a
// crash kills it. Each input must load within 10 s, and the process's peak
// memory must stay under 1 GB (2 GB under ASan, see below). Inputs that fail are saved under the
// scratch directory's `failures/`.
//
// ROS 1 bags (issue 29): our exporter's bag of one frame, uncompressed (so
// mutations reach the message fields, not only LZ4's stream), and the
// hostile bags of tests/data/crashers/bags_meshes, read as `detect --bag`
// reads them (TF included).
//
// Shared files of cluster runs and models (issue 39): jobs.json, evaluation
// shards, tune trial files and the model file's vote-network block.
//
// FURN_FUZZ_RUNS sets the mutations per target (default 300: the fast
// suite); FURN_FUZZ_SEED the seed (default 1). The slow suite runs 10^4.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <xxhash.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
// GCC 12 under -fsanitize=address warns of a maybe-uninitialised std::function
// inside <regex>'s compiler (a false positive; -Werror builds stop on it).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <regex>
#include <string>
#include <vector>

#include "core/learned/vote_net.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "core/util/progress.h"
#include "db/dataset_db.h"
#include "db/sqlite.h"
#include "scenes/catalog.h"
#include "scenes/mesh_io.h"
#include "tests/scenes/fixtures.h"
#include "tests/test_util.h"
#include "workbench/formats/camera_file.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/mcap.h"
#include "workbench/formats/options_file.h"
#include "workbench/formats/point_cloud_file.h"
#include "workbench/formats/ros2_bag.h"
#include "workbench/formats/ros2_messages.h"
#include "workbench/formats/ros_common.h"
#include "workbench/formats/rosbag_io.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/evaluated_frame.h"
#include "workbench/pipelines/slurm_jobs.h"
#include "workbench/pipelines/train.h"

#if defined(__SANITIZE_ADDRESS__)
// Under ASan (FURN_SANITIZE=address,...) the 1 GB rule holds per allocation:
// any single request above it is reported and ends the run. The process's
// resident size is not the loader's there: shadow memory and the quarantine
// of freed blocks grow over 10^5 inputs in one process (1.0 GB after 300 k
// class-map loads, no leak), so the peak bound is the issue's 2 GB.
extern "C" const char* __asan_default_options() {
  return "max_allocation_size_mb=1024:quarantine_size_mb=64";
}
constexpr double kPeakLimitGb = 2.0;
#else
constexpr double kPeakLimitGb = 1.0;
#endif

namespace furn {
namespace {

int EnvInt(const char* name, int fallback) {
  const char* text = std::getenv(name);
  return text != nullptr && *text != '\0' ? std::atoi(text) : fallback;
}

double PeakRssGb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / (1024.0 * 1024.0);  // kilobytes on Linux
}

// One mutation of `input`, drawn from `random`.
std::string Mutate(const std::string& input, std::mt19937_64& random) {
  std::string s = input.empty() ? std::string(1, '\0') : input;
  auto position = [&] { return std::uniform_int_distribution<size_t>(0, s.size() - 1)(random); };
  static const char* kNumbers[] = {"-1",
                                   "0",
                                   "65536",
                                   "2147483648",
                                   "4294967295",
                                   "4294967296",
                                   "1e30",
                                   "nan",
                                   "-2147483649",
                                   "99999999999999999999",
                                   "3",
                                   "1000000000"};
  static const uint8_t kBytes[] = {0x00, 0xff, 0x7f, 0x80, 0x01, 0xfe, '\n', ' '};
  const int kind = std::uniform_int_distribution<int>(0, 7)(random);
  switch (kind) {
    case 0: {  // flip a bit
      const size_t at = position();
      s[at] = static_cast<char>(s[at] ^ (1 << std::uniform_int_distribution<int>(0, 7)(random)));
      break;
    }
    case 1:  // an interesting byte
      s[position()] = static_cast<char>(kBytes[std::uniform_int_distribution<int>(0, 7)(random)]);
      break;
    case 2: {  // insert random bytes
      const size_t count = std::uniform_int_distribution<size_t>(1, 16)(random);
      std::string bytes;
      for (size_t k = 0; k < count; ++k)
        bytes += static_cast<char>(std::uniform_int_distribution<int>(0, 255)(random));
      s.insert(position(), bytes);
      break;
    }
    case 3: {  // delete a range
      const size_t at = position();
      s.erase(at, std::uniform_int_distribution<size_t>(1, 64)(random));
      break;
    }
    case 4: {  // repeat a range
      const size_t at = position();
      const std::string range = s.substr(at, std::uniform_int_distribution<size_t>(1, 64)(random));
      s.insert(at, range);
      break;
    }
    case 5:  // truncate
      s.resize(position());
      break;
    default: {  // a number in the text swapped for a hostile one
      std::vector<std::pair<size_t, size_t>> numbers;
      static const std::regex kNumber("-?[0-9]+(\\.[0-9]+)?(e[-+]?[0-9]+)?");
      const std::string head = s.substr(0, 4096);
      for (auto it = std::sregex_iterator(head.begin(), head.end(), kNumber);
           it != std::sregex_iterator();
           ++it)
        numbers.emplace_back(it->position(), it->length());
      if (numbers.empty()) {
        s[position()] ^= 0x20;
        break;
      }
      const auto [at, length] =
          numbers[std::uniform_int_distribution<size_t>(0, numbers.size() - 1)(random)];
      s.replace(at, length, kNumbers[std::uniform_int_distribution<int>(0, 11)(random)]);
    }
  }
  return s;
}

struct Target {
  std::string name, extension;
  std::vector<std::string> seeds;  // file contents
  std::function<void(const std::string& path)> load;
};

// Mutates the seeds `runs` times (1 to 3 mutations each) and loads each.
void Fuzz(const Target& target, const std::string& dir) {
  const int runs = EnvInt("FURN_FUZZ_RUNS", 300);
  std::mt19937_64 random(static_cast<uint64_t>(EnvInt("FURN_FUZZ_SEED", 1)) * 1000003u +
                         std::hash<std::string>{}(target.name));
  const std::string path = dir + "/input." + target.extension;
  int refused = 0, loaded = 0;
  double slowest_s = 0;
  for (int run = 0; run < runs; ++run) {
    std::string input = target.seeds[run % target.seeds.size()];
    const int mutations = std::uniform_int_distribution<int>(1, 3)(random);
    for (int m = 0; m < mutations; ++m) input = Mutate(input, random);
    WriteFileAtomically(path, input);
    const auto start = std::chrono::steady_clock::now();
    std::string failure;
    try {
      target.load(path);
      ++loaded;
    } catch (const InputError&) {
      ++refused;
    } catch (const DbError&) {
      ++refused;
    } catch (const std::exception& error) {
      failure = std::string("a library's exception escaped: ") + error.what();
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    slowest_s = std::max(slowest_s, seconds);
    // Long runs report as they go: a stopped run still says how far it got.
    if (runs >= 10000 && (run + 1) % (runs / 10) == 0) {
      std::printf("%s: %d of %d inputs, %d loaded, %d refused, slowest %.3f s, peak %.2f GB\n",
                  target.name.c_str(),
                  run + 1,
                  runs,
                  loaded,
                  refused,
                  slowest_s,
                  PeakRssGb());
      std::fflush(stdout);
    }
    if (seconds > 10) failure = "took " + std::to_string(seconds) + " s";
    if (!failure.empty()) {
      std::filesystem::create_directories(dir + "/failures");
      const std::string saved =
          dir + "/failures/" + target.name + "-" + std::to_string(run) + "." + target.extension;
      WriteFileAtomically(saved, input);
      ADD_FAILURE() << target.name << " run " << run << ": " << failure << " (input " << saved
                    << ")";
    }
  }
  EXPECT_LT(PeakRssGb(), kPeakLimitGb) << target.name << ": peak memory";
  std::printf("%s: %d inputs, %d loaded, %d refused with one line, slowest %.3f s, peak %.2f GB\n",
              target.name.c_str(),
              runs,
              loaded,
              refused,
              slowest_s,
              PeakRssGb());
}

std::string SmallPcdAscii() {
  std::string text =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4\n"
      "HEIGHT 3\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 12\nDATA ascii\n";
  for (int i = 0; i < 12; ++i)
    text += i == 5 ? "nan nan nan\n"
                   : std::to_string(0.1 * (i % 4)) + " " + std::to_string(0.1 * (i / 4)) + " 1.5\n";
  return text;
}

std::string SmallPcdBinary(const std::string& type, int size) {
  std::string text = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE " + std::to_string(size) + " " +
                     std::to_string(size) + " " + std::to_string(size) + "\nTYPE " + type + " " +
                     type + " " + type +
                     "\nCOUNT 1 1 1\nWIDTH 6\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\n"
                     "DATA binary\n";
  for (int i = 0; i < 18; ++i) {
    const double v = 0.25 * i + 1;
    if (size == 8) {
      text.append(reinterpret_cast<const char*>(&v), 8);
    } else {
      const float f = static_cast<float>(v);
      text.append(reinterpret_cast<const char*>(&f), 4);
    }
  }
  return text;
}

std::string SmallPly(bool binary) {
  std::string header = std::string("ply\nformat ") + (binary ? "binary_little_endian" : "ascii") +
                       " 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
                       "property double z\nelement face 2\nproperty list uchar int vertex_indices\n"
                       "end_header\n";
  const double points[4][3] = {{0, 0, 1}, {1, 0, 1}, {1, 1, 1.2}, {0, 1, 1.1}};
  if (!binary) {
    for (const auto& p : points)
      header +=
          std::to_string(p[0]) + " " + std::to_string(p[1]) + " " + std::to_string(p[2]) + "\n";
    return header + "3 0 1 2\n3 0 2 3\n";
  }
  for (const auto& p : points) header.append(reinterpret_cast<const char*>(p), 24);
  const int faces[2][3] = {{0, 1, 2}, {0, 2, 3}};
  for (const auto& f : faces) {
    header += '\3';
    header.append(reinterpret_cast<const char*>(f), 12);
  }
  return header;
}

DepthFrame SmallDepth() {
  DepthFrame frame;
  frame.Resize(16, 12);
  for (size_t i = 0; i < frame.depth.size(); ++i) frame.depth[i] = i % 7 == 0 ? 0 : 1 + 0.01f * i;
  return frame;
}

// A dataset of one room and one frame, generated by the workbench.
void GenerateSeedDataset(const std::string& path) {
  const testing::CommandResult made = testing::RunCommand(
      std::string(FURN_WORKBENCH_BINARY) +
      " generate --catalog procedural:2 --rooms 1 --frames 1 --seed 3 --quiet --out " + path);
  ASSERT_EQ(made.exit_code, 0) << made.output;
}

// Every entry of a catalog loaded, as `catalog list --load` does.
void LoadAllModels(const Catalog& catalog) {
  std::vector<std::string> ids;
  for (const CatalogEntry& entry : catalog.entries()) ids.push_back(entry.id);
  catalog.LoadModels(ids, /*show_progress=*/false);
}

// The model file the model targets mutate: k-means of 8 words over
// procedural:2 seen from one height and 3 azimuths (seconds to train).
void TrainSeedModel(const std::string& path) {
  ScanOptions scan;
  scan.heights_m = {1.2};
  scan.azimuths = 3;
  TrainerOptions trainer;
  trainer.vocabulary.kind = VocabularyKind::kKMeans;
  trainer.vocabulary.words = 8;
  TrainFromCatalog(OpenCatalog("procedural:2"), scan, trainer, path);
}

class LoaderFuzz : public ::testing::Test {
 protected:
  void SetUp() override {
    Progress::SetQuiet(true);
    dir_ = testing::ScratchDir();
  }
  std::string dir_;
};

TEST_F(LoaderFuzz, PointClouds) {
  const DepthFrame depth = SmallDepth();
  WriteOrganizedPcd(depth, CameraIntrinsics{16, 12, 20, 20, 7.5, 5.5}, dir_ + "/organised.pcd");
  Fuzz({"pcd",
        "pcd",
        {SmallPcdAscii(),
         SmallPcdBinary("F", 4),
         SmallPcdBinary("F", 8),
         ReadFileBytes(dir_ + "/organised.pcd")},
        [](const std::string& path) { ReadPointCloudFile(path); }},
       dir_);
  Fuzz({"ply",
        "ply",
        {SmallPly(false), SmallPly(true)},
        [](const std::string& path) { ReadPointCloudFile(path); }},
       dir_);
}

TEST_F(LoaderFuzz, DepthImages) {
  const std::vector<uint8_t> png = EncodeDepthPng(SmallDepth());
  Fuzz({"png",
        "png",
        {std::string(png.begin(), png.end())},
        [](const std::string& path) { ReadDepthImage(path, std::nullopt); }},
       dir_);
}

TEST_F(LoaderFuzz, CatalogsAndClassMaps) {
  const std::string sh3f = testing::WriteTestSh3f(dir_, "Test.sh3f");
  Fuzz({"sh3f",
        "sh3f",
        {ReadFileBytes(sh3f)},
        [&](const std::string& path) { LoadAllModels(OpenCatalog(path)); }},
       dir_);
  CatalogOpenOptions options;
  options.catalog_dir = dir_;
  Fuzz({"class_map",
        "json",
        {R"({"format": "furnidet-class-map", "version": 1, "catalogs": ["Test.sh3f"],
             "entries": [{"id": "Test/marker", "class": "chair"},
                         {"id": "Test/rotated", "class": "table", "evaluation_only": true}]})"},
        [&](const std::string& path) { LoadAllModels(OpenCatalog(path, options)); }},
       dir_);
}

// Mesh files a version-2 class map names: VTK legacy polydata (VTK's
// reader) and OBJ (assimp), through the loader every command uses.
TEST_F(LoaderFuzz, MeshFiles) {
  const std::string vtk =
      "# vtk DataFile Version 3.0\nbox\nASCII\nDATASET POLYDATA\nPOINTS 8 float\n"
      "0 0 0 0.8 0 0 0.8 0.4 0 0 0.4 0\n0 0 0.9 0.8 0 0.9 0.8 0.4 0.9 0 0.4 0.9\n"
      "POLYGONS 4 20\n4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n"
      "TRIANGLE_STRIPS 1 5\n4 2 3 6 7\n";
  const std::string obj =
      "v 0 0 0\nv 0.8 0 0\nv 0.8 0.4 0\nv 0 0.4 0\nv 0 0 0.9\nv 0.8 0 0.9\n"
      "f 1 2 3\nf 1 3 4\nf 1 2 6 5\n";
  Fuzz({"vtk", "vtk", {vtk}, [](const std::string& path) { LoadMeshFile(path); }}, dir_);
  Fuzz({"obj", "obj", {obj}, [](const std::string& path) { LoadMeshFile(path); }}, dir_);
}

TEST_F(LoaderFuzz, ModelFiles) {
  TrainSeedModel(dir_ + "/seed.fcm");
  Fuzz({"model",
        "fcm",
        {ReadFileBytes(dir_ + "/seed.fcm")},
        [](const std::string& path) { LoadTrainedModel(path); }},
       dir_);
}

// Model files past their checksum (issue 68): each mutant's checksum is made
// right again, so the parser and then detection meet the mutated fields.
TEST_F(LoaderFuzz, ModelFilesThroughDetection) {
  TrainSeedModel(dir_ + "/seed.fcm");
  ASSERT_NO_FATAL_FAILURE(GenerateSeedDataset(dir_ + "/seed.db"));
  DetectionInput frame;
  {
    DatasetDb db(dir_ + "/seed.db", DatasetDb::Mode::kReadOnly);
    const RoomRecord room = db.ReadRoom(db.RoomIds().at(0), /*with_images=*/true);
    frame = DetectionInputOf(room.frames.at(0), "seed frame");
  }
  Fuzz({"model_through_detection",
        "fcm",
        {ReadFileBytes(dir_ + "/seed.fcm")},
        [&frame](const std::string& path) {
          std::string bytes = ReadFileBytes(path);
          constexpr size_t kHeader = 12;  // magic and version, outside the checksum
          if (bytes.size() >= kHeader + 8) {
            const uint64_t checksum =
                XXH3_64bits(bytes.data() + kHeader, bytes.size() - kHeader - 8);
            std::memcpy(&bytes[bytes.size() - 8], &checksum, sizeof(checksum));
            WriteFileAtomically(path, bytes);
          }
          const Detector detector(LoadTrainedModel(path), DetectorOptions{});
          detector.Detect(frame);
        }},
       dir_);
}

// Options files (issue 68): every detector option from a file someone else
// wrote is bounded by its Check.
TEST_F(LoaderFuzz, OptionsFiles) {
  Fuzz({"options_file",
        "json",
        {OptionsFileJson(TrainingOptions{}, DetectorOptions{})},
        [](const std::string& path) {
          DetectorOptionsFromJson(ReadFileBytes(path), path).Check();
          TrainingOptionsFromJson(ReadFileBytes(path), path);
        }},
       dir_);
}

TEST_F(LoaderFuzz, DatasetDatabases) {
  ASSERT_NO_FATAL_FAILURE(GenerateSeedDataset(dir_ + "/seed.db"));
  Fuzz({"dataset_db",
        "db",
        {ReadFileBytes(dir_ + "/seed.db")},
        [](const std::string& path) {
          DatasetDb db(path, DatasetDb::Mode::kReadOnly);
          db.ReadModels();
          db.Runs();
          for (int64_t id : db.RoomIds()) {
            const RoomRecord room = db.ReadRoom(id, /*with_images=*/true);
            for (const FrameRecord& frame : room.frames) DetectionInputOf(frame, path);
          }
        }},
       dir_);
}

TEST_F(LoaderFuzz, RosBags) {
  ASSERT_NO_FATAL_FAILURE(GenerateSeedDataset(dir_ + "/seed.db"));
  std::vector<std::string> seeds;
  try {
    DatasetDb db(dir_ + "/seed.db", DatasetDb::Mode::kReadOnly);
    const RoomRecord room = db.ReadRoom(db.RoomIds().at(0), /*with_images=*/true);
    FrameBagWriter writer(dir_ + "/seed.bag", /*compress=*/false);
    writer.Write(room, room.frames.at(0), "seed frame");
    writer.Finish();
    seeds.push_back(ReadFileBytes(dir_ + "/seed.bag"));
  } catch (const InputError& error) {  // a build without ROS: the crashers alone
    std::printf("no seed bag: %s\n", error.what());
  }
  const std::string crashers = FURN_SOURCE_DIR "/tests/data/crashers/bags_meshes/";
  for (const char* name :
       {"image_data_len_4G.bag", "tf_count_16M.bag", "index_offset_past_chunk.bag"})
    seeds.push_back(ReadFileBytes(crashers + name));
  Fuzz({"rosbag",
        "bag",
        seeds,
        [](const std::string& path) {
          BagScanOptions options;
          options.bag_path = path;
          options.topic = "/camera/depth/image_raw";
          ForEachBagScan(options, [](const BagScan&) {});
        }},
       dir_);
}

// ROS 2 bags' SQLite files (issue 68): a frame exported as rosbag2 writes
// it, each mutant read as a bag.
TEST_F(LoaderFuzz, Ros2Bags) {
  ASSERT_NO_FATAL_FAILURE(GenerateSeedDataset(dir_ + "/seed.db"));
  {
    DatasetDb db(dir_ + "/seed.db", DatasetDb::Mode::kReadOnly);
    const RoomRecord room = db.ReadRoom(db.RoomIds().at(0), /*with_images=*/true);
    Ros2FrameWriter writer(dir_ + "/seed_ros2");
    writer.Write(room, room.frames.at(0), "seed frame");
    writer.Finish();
  }
  Fuzz({"ros2_bag",
        "db3",
        {ReadFileBytes(dir_ + "/seed_ros2/seed_ros2_0.db3")},
        [](const std::string& path) {
          BagScanOptions options;
          options.bag_path = path;
          options.topic = "/camera/depth/image_raw";
          ForEachScanInBag(options, [](const BagScan&) {});
        }},
       dir_);
}

// MCAP bags (ROS 2 Iron and later): the exporter's frame in each chunk
// compression; the uncompressed seed lets mutations reach the records and
// message fields, the compressed ones the decompressors' bounds.
TEST_F(LoaderFuzz, Ros2McapBags) {
  ASSERT_NO_FATAL_FAILURE(GenerateSeedDataset(dir_ + "/seed.db"));
  std::vector<std::string> seeds;
  DatasetDb db(dir_ + "/seed.db", DatasetDb::Mode::kReadOnly);
  const RoomRecord room = db.ReadRoom(db.RoomIds().at(0), /*with_images=*/true);
  for (McapCompression compression :
       {McapCompression::kNone, McapCompression::kZstd, McapCompression::kLz4}) {
    const std::string bag = dir_ + "/seed_mcap_" + McapCompressionName(compression);
    {
      Ros2BagWriter writer(bag, Ros2Storage::kMcap, compression);
      const RecordedFrame frame = RecordFrame(room, room.frames.at(0), 0, "seed frame");
      writer.Write("/tf", kRos2TfMessage, 1, EncodeTfMessage({frame.world_from_camera}));
      writer.Write("/camera/depth/camera_info", kRos2CameraInfo, 1, EncodeCameraInfo(frame.info));
      writer.Write("/camera/depth/image_raw", kRos2Image, 1, EncodeImage(frame.depth));
      writer.Finish();
    }
    seeds.push_back(
        ReadFileBytes(bag + "/" + std::filesystem::path(bag).filename().string() + "_0.mcap"));
  }
  Fuzz({"ros2_mcap",
        "mcap",
        seeds,
        [](const std::string& path) {
          BagScanOptions options;
          options.bag_path = path;
          options.topic = "/camera/depth/image_raw";
          options.world_frame = "world";
          ForEachScanInBag(options, [](const BagScan&) {});
        }},
       dir_);
}

// Camera files of every kind ReadCameraFile reads (issue 29).
TEST_F(LoaderFuzz, CameraFiles) {
  Fuzz({"camera_json",
        "json",
        {R"({"fx": 525, "fy": 525, "cx": 319.5, "cy": 239.5, "width": 640, "height": 480,
             "depth_scale": 1.0})",
         R"({"3": {"cam_K": [600, 0, 320, 0, 601, 200, 0, 0, 1], "depth_scale": 0.5}})"},
        [](const std::string& path) { ReadCameraFile(path, 3); }},
       dir_);
  Fuzz({"camera_yaml",
        "yaml",
        {"image_width: 640\nimage_height: 480\ncamera_name: depth\ncamera_matrix:\n  rows: 3\n"
         "  cols: 3\n  data: [570.3, 0, 319.5, 0, 570.3, 239.5, 0, 0, 1]\n",
         "header:\n  seq: 4\n  frame_id: camera\nheight: 480\nwidth: 640\n"
         "distortion_model: plumb_bob\nD: [0.0, 0.0, 0.0, 0.0, 0.0]\n"
         "K: [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0]\n---\n"},
        [](const std::string& path) { ReadCameraFile(path); }},
       dir_);
}

// Version-2 class maps naming mesh files, with units, axes and sizes, loaded
// as every command loads them (issue 29).
TEST_F(LoaderFuzz, ClassMapsVersion2) {
  testing::WriteText(dir_ + "/chair.obj",
                     "v 0 0 0\nv 0.5 0 0\nv 0.5 0.5 0\nv 0 0.5 0\nv 0 0 0.9\nv 0.5 0 0.9\n"
                     "f 1 2 3\nf 1 3 4\nf 1 2 6 5\n");
  testing::WriteText(dir_ + "/table.off",
                     "OFF\n4 2 0\n0 0 0\n120 0 0\n120 80 75\n0 80 75\n3 0 1 2\n3 0 2 3\n");
  Fuzz({"class_map_v2",
        "json",
        {R"({"format": "furnidet-class-map", "version": 2, "entries": [
             {"id": "c", "class": "chair", "mesh": "chair.obj", "units": "m", "up": "z",
              "front": "-y"},
             {"id": "t", "class": "table", "mesh": "table.off", "units": "cm",
              "size": [1.2, 0.8, 0.75]},
             {"id": "k", "class": "clutter", "mesh": "chair.obj", "units": 0.5}]})"},
        [&](const std::string& path) { LoadAllModels(OpenCatalog(path)); }},
       dir_);
}

}  // namespace
}  // namespace furn

namespace furn {
namespace {

// Issue 39: the files a cluster run shares — a job folder's jobs.json, an
// evaluation shard and a tune trial file (the same format) — and the model
// file's vote-network block. squeue is kept out of reach (an empty PATH): a
// job id reaching it would be a process per input, and none may run.
class SharedFileFuzz : public ::testing::Test {
 protected:
  void SetUp() override {
    Progress::SetQuiet(true);
    dir_ = testing::ScratchDir();
    const char* path = std::getenv("PATH");
    saved_path_ = path ? path : "";
    std::filesystem::create_directories(dir_ + "/empty_path");
    setenv("PATH", (dir_ + "/empty_path").c_str(), 1);
  }
  void TearDown() override { setenv("PATH", saved_path_.c_str(), 1); }
  std::string dir_, saved_path_;
};

EvaluatedFrame SmallEvaluatedFrame(int position) {
  EvaluatedFrame frame;
  frame.position = position;
  frame.outcome.frame_id = 40 + position;
  frame.outcome.total_ms = 12.5;
  frame.outcome.stage_ms[DetectionStage::kNetwork] = 3.5;
  ScoredDetection d;
  d.furniture_class = FurnitureClass::kTable;
  d.model_id = "Scopia/table";
  d.x = 1.5;
  d.y = -0.25;
  d.yaw = 0.5;
  d.score = 0.7;
  d.width = 1.2;
  d.depth = 0.8;
  frame.outcome.detections.push_back(d);
  frame.detections.push_back({frame.outcome.frame_id,
                              d.furniture_class,
                              d.model_id,
                              d.x,
                              d.y,
                              0,
                              d.yaw,
                              d.score,
                              0.7,
                              0.8,
                              0.9});
  frame.outcome.maxima.push_back(
      {FurnitureClass::kChair, 2.0, 1.0, 0.4, HypothesisOutcome::kBelowOperatingPoint});
  frame.record = {frame.outcome.frame_id, 12.5, "{\"network\": 3.5}"};
  return frame;
}

TEST_F(SharedFileFuzz, JobFolders) {
  ArrayJob job;
  job.dir = dir_ + "/seed_job";
  job.name = "evaluate";
  job.tasks = 3;
  job.task_command = "workbench evaluate --shard \"$TASK\"/3";
  job.task_output = dir_ + "/seed_job/shard-$TASK.json";
  job.final_command = "workbench evaluate --merge-shards a b c";
  EmitArrayJob(job);
  std::string seed = ReadFileBytes(job.dir + "/jobs.json");
  // One with submissions, as `--slurm` leaves it.
  std::string submitted = seed;
  submitted.replace(submitted.find("\"submissions\": []"),
                    17,
                    "\"submissions\": [{\"array\": \"123\", \"tasks\": [0, 1, 2], \"final\": "
                    "\"124\"}, {\"array\": \"130_2\", \"tasks\": [2], \"final\": \"\"}]");
  const std::string folder = dir_ + "/fuzzed_job";
  std::filesystem::create_directories(folder + "/status");
  WriteFileAtomically(folder + "/status/task-1.failed", "3\n");
  Fuzz({"jobs_json",
        "json",
        {seed, submitted},
        [&](const std::string& path) {
          std::filesystem::copy_file(
              path, folder + "/jobs.json", std::filesystem::copy_options::overwrite_existing);
          ReadJobFolder(folder);
        }},
       dir_);
}

TEST_F(SharedFileFuzz, EvaluationShardsAndTuneTrials) {
  const std::vector<EvaluatedFrame> frames = {SmallEvaluatedFrame(0), SmallEvaluatedFrame(2)};
  WriteShardFile(dir_ + "/shard.json", {0, 2, "abc", "def", "{\"detector\": {}}"}, frames);
  WriteShardFile(dir_ + "/trial.json",
                 {0, 1, "abc", "def", "{\"tune\": {\"id\": \"0123\", \"trial\": 3, \"seed\": 0}}"},
                 frames);
  Fuzz({"eval_shard",
        "json",
        {ReadFileBytes(dir_ + "/shard.json")},
        [](const std::string& path) { ParseShardFile(path); }},
       dir_);
  Fuzz({"tune_trial",
        "json",
        {ReadFileBytes(dir_ + "/trial.json")},
        [](const std::string& path) { ParseShardFile(path); }},
       dir_);
}

TEST_F(SharedFileFuzz, VoteNetworkBlocks) {
  VoteNetOptions options;
  options.grid.cell_m = 0.1;
  options.grid.rows = 16;
  options.grid.cols = 16;
  options.width = 4;
  const std::string seed = VoteNet::Create(options, 1).Serialize();
  Fuzz({"vote_net",
        "bin",
        {seed},
        [](const std::string& path) { VoteNet::Deserialize(ReadFileBytes(path), path); }},
       dir_);
}

}  // namespace
}  // namespace furn
