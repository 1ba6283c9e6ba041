// NYU Depth V2 as a real validation set, on synthetic stand-ins (the real
// frames are research-use and never on CI): MAT-file split reading, the
// conversion's split rules, its floors and instances against a scene whose
// truth is exact, and the floor check of the detector's floor search.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/geometry/floor.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "tests/test_util.h"
#include "workbench/formats/mat_file.h"
#include "workbench/formats/real_labels.h"
#include "workbench/pipelines/convert_nyu.h"
#include "workbench/pipelines/floor_check.h"
#include "workbench/pipelines/import_real.h"

namespace fs = std::filesystem;

namespace furn {
namespace {

// --- MAT-file writing (level 5), enough for a split file -------------------

void AppendU32(std::string* out, uint32_t value) {
  out->append(reinterpret_cast<const char*>(&value), 4);
}
void Pad8(std::string* out) { out->append((8 - out->size() % 8) % 8, '\0'); }

// A miMATRIX element of a uint16 column vector (how NYU stores its indices).
std::string MatrixElement(const std::string& name, const std::vector<uint16_t>& values) {
  std::string body;
  AppendU32(&body, 6);  // miUINT32 flags
  AppendU32(&body, 8);
  AppendU32(&body, 6);  // class mxDOUBLE (MATLAB stores the data as uint16 when it fits)
  AppendU32(&body, 0);
  AppendU32(&body, 5);  // miINT32 dimensions
  AppendU32(&body, 8);
  AppendU32(&body, static_cast<uint32_t>(values.size()));
  AppendU32(&body, 1);
  AppendU32(&body, 1);  // miINT8 name
  AppendU32(&body, static_cast<uint32_t>(name.size()));
  body += name;
  Pad8(&body);
  AppendU32(&body, 4);  // miUINT16 data
  AppendU32(&body, static_cast<uint32_t>(values.size() * 2));
  body.append(reinterpret_cast<const char*>(values.data()), values.size() * 2);
  Pad8(&body);
  std::string element;
  AppendU32(&element, 14);
  AppendU32(&element, static_cast<uint32_t>(body.size()));
  return element + body;
}

std::string Compressed(const std::string& element) {
  uLongf size = compressBound(element.size());
  std::string packed(size, '\0');
  compress(reinterpret_cast<Bytef*>(packed.data()),
           &size,
           reinterpret_cast<const Bytef*>(element.data()),
           element.size());
  packed.resize(size);
  std::string out;
  AppendU32(&out, 15);
  AppendU32(&out, static_cast<uint32_t>(packed.size()));
  return out + packed;
}

std::string MatHeader() {
  std::string header = "MATLAB 5.0 MAT-file, written by a furnidet test";
  header.resize(124, ' ');
  header += std::string("\x00\x01", 2) + "IM";
  return header;
}

std::string SplitFile(const std::vector<uint16_t>& train,
                      const std::vector<uint16_t>& test,
                      bool compressed = true) {
  const std::string a = MatrixElement("trainNdxs", train), b = MatrixElement("testNdxs", test);
  return MatHeader() + (compressed ? Compressed(a) + Compressed(b) : a + b);
}

TEST(MatFile, ReadsCompressedAndPlainNumericArrays) {
  for (bool compressed : {true, false}) {
    const MatArrays arrays = ParseMatFile(SplitFile({3, 4, 10}, {1, 2}, compressed), "s.mat");
    ASSERT_EQ(arrays.size(), 2u);
    EXPECT_EQ(arrays.at("trainNdxs").values, (std::vector<double>{3, 4, 10}));
    EXPECT_EQ(arrays.at("trainNdxs").dimensions, (std::vector<int64_t>{3, 1}));
    EXPECT_EQ(arrays.at("testNdxs").values, (std::vector<double>{1, 2}));
  }
}

TEST(MatFile, MalformedFilesAreNamedErrors) {
  const std::string good = SplitFile({3, 4}, {1});
  EXPECT_NE(testing::ErrorOf([] { ParseMatFile("hello", "s.mat"); }).find("not a MATLAB 5.0"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] {
              ParseMatFile(good.substr(0, good.size() - 9), "s.mat");
            }).find("s.mat: "),
            std::string::npos);
  // Dimensions claiming more values than are stored.
  std::string plain = SplitFile({3, 4}, {1}, false);
  const size_t dims = plain.find(std::string("\x05\x00\x00\x00\x08\x00\x00\x00", 8));
  ASSERT_NE(dims, std::string::npos);
  plain[dims + 8] = 100;
  EXPECT_NE(testing::ErrorOf([&] { ParseMatFile(plain, "s.mat"); }).find("values for dimensions"),
            std::string::npos);
  // A data element claiming 4 GB of a 200-byte file: refused, not allocated.
  std::string huge = SplitFile({3, 4}, {1}, false);
  const uint32_t claim = 0xfffffff0u;
  std::memcpy(&huge[128 + 4], &claim, 4);
  EXPECT_NE(testing::ErrorOf([&] { ParseMatFile(huge, "s.mat"); }).find("runs past the end"),
            std::string::npos);
}

TEST(MatFile, ACompressedElementInflatingPastTheCapIsRefused) {
  // 300 MiB of zeros deflate to about 300 KB; inflating stops at the cap.
  z_stream stream{};
  ASSERT_EQ(deflateInit(&stream, 1), Z_OK);
  const std::vector<char> zeros(1 << 20, 0);
  std::string packed;
  std::vector<char> buffer(1 << 16);
  for (int chunk = 0; chunk < 300; ++chunk) {
    stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(zeros.data()));
    stream.avail_in = static_cast<uInt>(zeros.size());
    const int flush = chunk == 299 ? Z_FINISH : Z_NO_FLUSH;
    do {
      stream.next_out = reinterpret_cast<Bytef*>(buffer.data());
      stream.avail_out = static_cast<uInt>(buffer.size());
      deflate(&stream, flush);
      packed.append(buffer.data(), buffer.size() - stream.avail_out);
    } while (stream.avail_out == 0);
  }
  deflateEnd(&stream);
  std::string file = MatHeader();
  AppendU32(&file, 15);
  AppendU32(&file, static_cast<uint32_t>(packed.size()));
  file += packed;
  EXPECT_NE(testing::ErrorOf([&] { ParseMatFile(file, "bomb.mat"); }).find("inflates past 256 MiB"),
            std::string::npos);
}

// --- A synthetic NYU frame --------------------------------------------------

// A box on the floor (world frame: z up).
struct Box {
  Eigen::Vector3d low, high;
  int nyu_id;  // NYU-40
};

// The camera `height` m above the floor, looking along +x pitched down.
Eigen::Isometry3d CameraPose(double height, double pitch_deg) {
  const double t = pitch_deg * M_PI / 180;
  Eigen::Matrix3d rotation;
  rotation.col(0) = Eigen::Vector3d(0, -1, 0);                       // right
  rotation.col(1) = Eigen::Vector3d(-std::sin(t), 0, -std::cos(t));  // down
  rotation.col(2) = Eigen::Vector3d(std::cos(t), 0, -std::sin(t));   // forward
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = Eigen::Vector3d(0, 0, height);
  return pose;
}

// Ray distance to an axis-aligned box (slabs), or infinity.
double HitBox(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray, const Box& box) {
  double near = 0, far = 1e9;
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(ray[axis]) < 1e-12) {
      if (origin[axis] < box.low[axis] || origin[axis] > box.high[axis]) return 1e18;
      continue;
    }
    double a = (box.low[axis] - origin[axis]) / ray[axis];
    double b = (box.high[axis] - origin[axis]) / ray[axis];
    if (a > b) std::swap(a, b);
    near = std::max(near, a);
    far = std::min(far, b);
  }
  return near <= far ? near : 1e18;
}

// Writes frame `file_index` as the public repository stores it: mirrored,
// 8-bit depth in steps of kNyuDepthStep, labels = NYU-40 id - 1 (unlabelled: 39, as the source
// stores it); `ceiling_m` > 0 adds a ceiling plane at that height.
void WriteNyuFrame(const std::string& source,
                   int file_index,
                   const Eigen::Isometry3d& pose,
                   const std::vector<Box>& boxes,
                   double ceiling_m = 0) {
  cv::Mat depth(kNyuHeight, kNyuWidth, CV_8UC1), labels(kNyuHeight, kNyuWidth, CV_8UC1);
  for (int v = 0; v < kNyuHeight; ++v) {
    for (int u = 0; u < kNyuWidth; ++u) {
      const Eigen::Vector3d ray_camera((u - kNyuCx) / kNyuFx, (v - kNyuCy) / kNyuFy, 1);
      const Eigen::Vector3d ray = pose.linear() * ray_camera, origin = pose.translation();
      double best = 1e18;
      int id = 0;
      if (ray.z() < 0) best = -origin.z() / ray.z(), id = 2;  // floor
      if (ceiling_m > 0 && ray.z() > 0 && (ceiling_m - origin.z()) / ray.z() < best)
        best = (ceiling_m - origin.z()) / ray.z(), id = 22;
      for (const Box& box : boxes) {
        const double t = HitBox(origin, ray, box);
        if (t < best) best = t, id = box.nyu_id;
      }
      // Depth along the optical axis is t (the ray's z in the camera is 1).
      const int step = best > 9.9 ? 0 : static_cast<int>(best / kNyuDepthStep);
      depth.at<uint8_t>(v, kNyuWidth - 1 - u) = static_cast<uint8_t>(std::clamp(step, 0, 255));
      labels.at<uint8_t>(v, kNyuWidth - 1 - u) = static_cast<uint8_t>(id == 0 ? 39 : id - 1);
    }
  }
  for (const char* folder : {"nyu_depths", "nyu_labels40"})
    fs::create_directories(fs::path(source) / "data" / folder);
  const std::string name = std::to_string(file_index) + ".png";
  ASSERT_TRUE(cv::imwrite(source + "/data/nyu_depths/" + name, depth));
  ASSERT_TRUE(cv::imwrite(source + "/data/nyu_labels40/" + name, labels));
}

const std::vector<Box> kFurniture = {
    {{2.0, -0.7, 0}, {2.45, -0.25, 0.9}, 5},  // a chair, 0.45 m square
    {{2.2, 0.3, 0}, {3.0, 1.1, 0.75}, 7},     // a table, 0.8 m square
};

TEST(ConvertNyu, ConvertsOnlyTheTrainSplitWithFloorsAndInstances) {
  const std::string dir = testing::ScratchDir();
  const std::string source = dir + "/nyu";
  const Eigen::Isometry3d pose = CameraPose(1.3, 25);
  for (int index : {1, 2, 3, 1331}) WriteNyuFrame(source, index - 1, pose, kFurniture);
  testing::WriteText(dir + "/splits.mat", SplitFile({1, 2, 1331}, {3}));
  NyuConvertOptions options;
  options.source_dir = source;
  options.splits_path = dir + "/splits.mat";
  options.out_dir = dir + "/out";
  const NyuConvertSummary summary = ConvertNyu(options);
  EXPECT_EQ(summary.train_frames, 2);  // 1331 is held out, 3 is a test frame
  EXPECT_EQ(summary.frames, 2);
  const RealSet set = ReadRealSet(dir + "/out/labels.json");
  ASSERT_EQ(set.scans.size(), 2u);
  EXPECT_EQ(set.scans[0].id, "nyu-0001");
  EXPECT_EQ(set.scans[1].id, "nyu-0002");
  // The floor frame: 1.3 m below the camera, pitch 25 degrees (within one
  // depth step of quantisation).
  const Eigen::Isometry3d& frame = *set.scans[0].label_frame;
  EXPECT_NEAR(frame.translation().z(), 1.3, 0.03);
  const Eigen::Vector3d up_in_camera = frame.linear().row(2).transpose();
  const Eigen::Vector3d true_up = pose.linear().row(2).transpose();
  EXPECT_LT(std::acos(std::min(1.0, up_in_camera.dot(true_up))) * 180 / M_PI, 1.0);
  // Both pieces of furniture, in their class, centred within 0.1 m of the
  // truth (the frame's x is the camera's view, as the scene's).
  ASSERT_EQ(set.scans[0].objects.size(), 2u);
  for (const RealObject& object : set.scans[0].objects) {
    const bool chair = object.furniture_class == FurnitureClass::kChair;
    EXPECT_TRUE(chair || object.furniture_class == FurnitureClass::kTable);
    const Box& box = kFurniture[chair ? 0 : 1];
    const Eigen::Vector3d centre = (box.low + box.high) / 2;
    EXPECT_NEAR(object.x, centre.x(), 0.1) << ClassName(object.furniture_class);
    EXPECT_NEAR(object.y, centre.y(), 0.1) << ClassName(object.furniture_class);
    EXPECT_NEAR(object.size.z(), box.high.z(), 0.06);
    EXPECT_EQ(object.visibility, 1);
  }
  // Nothing of the held-out or test frames was written.
  EXPECT_FALSE(fs::exists(dir + "/out/depth/nyu-1331.png"));
  EXPECT_FALSE(fs::exists(dir + "/out/depth/nyu-0003.png"));
}

TEST(ConvertNyu, RefusesWhatTheRulesForbidAndWritesNothing) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/both.mat", SplitFile({1, 2}, {2}));
  NyuConvertOptions options;
  options.source_dir = dir + "/missing";
  options.splits_path = dir + "/both.mat";
  options.out_dir = dir + "/out";
  EXPECT_NE(testing::ErrorOf([&] { ConvertNyu(options); }).find("in both trainNdxs and testNdxs"),
            std::string::npos);
  testing::WriteText(dir + "/ok.mat", SplitFile({1}, {2}));
  options.splits_path = dir + "/ok.mat";
  EXPECT_NE(testing::ErrorOf([&] { ConvertNyu(options); }).find("0.png"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir + "/out"));
  EXPECT_TRUE(IsNyuHeldOut(1330) && IsNyuHeldOut(1350) && IsNyuHeldOut(1400) && IsNyuHeldOut(1420));
  EXPECT_FALSE(IsNyuHeldOut(1329) || IsNyuHeldOut(1351) || IsNyuHeldOut(1421));
}

TEST(ConvertNyu, InstancesCutByTheImageEdgeOrFarAreIgnored) {
  std::vector<float> depth(kNyuWidth * kNyuHeight);
  std::vector<uint8_t> labels(depth.size());
  const std::string dir = testing::ScratchDir();
  const Eigen::Isometry3d pose = CameraPose(1.3, 25);
  WriteNyuFrame(dir,
                0,
                pose,
                {{{1.6, -1.6, 0}, {2.1, -1.0, 0.9}, 5},     // a chair at the image's right edge
                 {{4.0, -0.2, 0}, {4.45, 0.25, 0.9}, 5}});  // a chair 4.2 m away
  cv::Mat d = cv::imread(dir + "/data/nyu_depths/0.png", cv::IMREAD_UNCHANGED);
  cv::Mat l = cv::imread(dir + "/data/nyu_labels40/0.png", cv::IMREAD_UNCHANGED);
  cv::flip(d, d, 1);
  cv::flip(l, l, 1);
  labels.assign(l.datastart, l.dataend);
  const std::vector<uint8_t> steps(d.datastart, d.dataend);
  for (int v = 0; v < kNyuHeight; ++v) {
    for (int u = 0; u < kNyuWidth; ++u)
      depth[v * kNyuWidth + u] = DequantisedNyuDepth(steps, u, v, 0);
  }
  const NyuFrameLabels frame = DeriveNyuLabels(depth, labels, NyuDeriveOptions{});
  ASSERT_TRUE(frame.usable) << frame.reason;
  ASSERT_EQ(frame.instances.size(), 2u);
  std::set<std::string> reasons;
  for (const NyuInstance& instance : frame.instances) reasons.insert(instance.ignored);
  EXPECT_TRUE(reasons.count("cut by the image edge"));
  EXPECT_TRUE(reasons.count("beyond the range"));
}

TEST(ConvertNyu, DequantisingRemovesTheDepthStepsButNotTheEdges) {
  // A plane sloping from 2 m to 3.5 m across the image, in 8-bit steps, with
  // a box 1 m nearer in the middle.
  cv::Mat steps(kNyuHeight, kNyuWidth, CV_8UC1);
  std::vector<double> truth(kNyuWidth * kNyuHeight);
  for (int v = 0; v < kNyuHeight; ++v) {
    for (int u = 0; u < kNyuWidth; ++u) {
      const bool box = std::abs(u - 320) < 60 && std::abs(v - 240) < 60;
      const double depth = 2.0 + 1.5 * u / kNyuWidth - (box ? 1.0 : 0.0);
      truth[v * kNyuWidth + u] = depth;
      steps.at<uint8_t>(v, u) = static_cast<uint8_t>(depth / kNyuDepthStep);
    }
  }
  const std::vector<uint8_t> step_values(steps.datastart, steps.dataend);
  auto rms = [&](int radius, bool edges_only) {
    double squares = 0;
    int n = 0;
    for (int v = 10; v < kNyuHeight - 10; ++v) {
      for (int u = 10; u < kNyuWidth - 10; ++u) {
        const bool near_edge = std::abs(std::abs(u - 320) - 60) <= 3 && std::abs(v - 240) < 60;
        if (edges_only != near_edge) continue;
        const double e = DequantisedNyuDepth(step_values, u, v, radius) - truth[v * kNyuWidth + u];
        squares += e * e;
        ++n;
      }
    }
    return std::sqrt(squares / n);
  };
  EXPECT_GT(rms(0, false), 0.010);  // uniform over a 3.9 cm step: 1.1 cm
  EXPECT_LT(rms(5, false), 0.005);
  EXPECT_LT(rms(5, true), 0.03);  // the box's sides keep their depth
}

// --- The floor check --------------------------------------------------------

TEST(FloorCheck, TheDetectorsFloorOnConvertedFramesAndNotTheCeiling) {
  const std::string dir = testing::ScratchDir();
  const std::string source = dir + "/nyu";
  // Frame 1: floor and furniture. Frame 2: a camera pitched up under a low
  // ceiling that fills most of the view, the floor a band at the bottom.
  WriteNyuFrame(source, 0, CameraPose(1.3, 25), kFurniture);
  WriteNyuFrame(source, 1, CameraPose(1.0, -12), kFurniture, 2.3);
  testing::WriteText(dir + "/splits.mat", SplitFile({1, 2}, {3}));
  NyuConvertOptions options;
  options.source_dir = source;
  options.splits_path = dir + "/splits.mat";
  options.out_dir = dir + "/out";
  options.derive.min_floor_pixels = 2000;
  ASSERT_EQ(ConvertNyu(options).frames, 2);
  ImportRealSet(ReadRealSet(dir + "/out/labels.json"), dir + "/real.db");
  const FloorCheck check = CheckFloors(dir + "/real.db", FloorOptions{}, FloorCheckOptions{});
  ASSERT_EQ(check.frames.size(), 2u);
  for (const FloorCheckFrame& frame : check.frames) {
    EXPECT_EQ(frame.outcome, FloorOutcome::kRight)
        << frame.name << ": " << EnumName(frame.outcome) << " " << frame.message;
    EXPECT_LT(frame.angle_deg, 2.0);
    EXPECT_LT(std::abs(frame.height_error_m), 0.05);
  }
  EXPECT_NE(FloorCheckText(check).find("2 right (100.0 %)"), std::string::npos);
}

}  // namespace
}  // namespace furn
