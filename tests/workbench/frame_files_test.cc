#include "reports/frame_preview.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/point_cloud_file.h"
#include "workbench/formats/point_fields.h"

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "core/util/error.h"
#include "renderers/depth_renderer.h"
#include "renderers/kinect_noise.h"
#include "tests/renderers/render_fixtures.h"
#include "tests/test_util.h"

namespace furn {
namespace {

DepthFrame BoxScene() {
  Scene scene;
  scene.objects.push_back(testing::WallAt(3.0));
  scene.objects.push_back(testing::BoxAt(1.5, -0.2, 0.2, -0.2, 0.2, 42));
  return MakeRenderer(RendererKind::kEmbree)
      ->Render(scene, CameraIntrinsics::KinectV1(), testing::CameraAtOriginLookingAlongY());
}

TEST(FrameIo, DepthPngRoundTripsToTheMillimetre) {
  const std::string dir = testing::ScratchDir();
  DepthFrame frame = BoxScene();
  frame.depth[0] = 0;  // no return stays no return
  WriteDepthPng(frame, dir + "/d.png");
  const DepthFrame back = ReadDepthPng(dir + "/d.png");
  ASSERT_EQ(back.width, 640);
  for (size_t i = 0; i < frame.depth.size(); i += 97) {
    EXPECT_NEAR(back.depth[i], frame.depth[i], 0.0005f);
  }
  EXPECT_EQ(back.depth[0], 0.0f);
  const cv::Mat raw = cv::imread(dir + "/d.png", cv::IMREAD_UNCHANGED);
  EXPECT_EQ(raw.type(), CV_16UC1);
  EXPECT_EQ(raw.at<uint16_t>(240, 320), 1500);
  // TUM scale 5000: 1.5 m is 7500.
  WriteDepthPng(frame, dir + "/tum.png", 5000);
  EXPECT_EQ(cv::imread(dir + "/tum.png", cv::IMREAD_UNCHANGED).at<uint16_t>(240, 320), 7500);
  EXPECT_NEAR(ReadDepthPng(dir + "/tum.png", 5000).DepthAt(320, 240), 1.5f, 1e-4f);
}

TEST(FrameIo, IdPngKeepsIds) {
  const std::string dir = testing::ScratchDir();
  WriteIdPng(BoxScene(), dir + "/ids.png");
  const cv::Mat raw = cv::imread(dir + "/ids.png", cv::IMREAD_UNCHANGED);
  EXPECT_EQ(raw.type(), CV_16UC1);
  EXPECT_EQ(raw.at<uint16_t>(240, 320), 42);
  EXPECT_EQ(raw.at<uint16_t>(5, 5), kWallId);
}

TEST(FrameIo, OrganizedPcdReadsBackInPcl) {
  const std::string dir = testing::ScratchDir();
  DepthFrame frame = BoxScene();
  frame.depth[frame.Index(0, 0)] = 0;
  WriteOrganizedPcd(frame, CameraIntrinsics::KinectV1(), dir + "/c.pcd");
  pcl::PointCloud<pcl::PointXYZ> cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(dir + "/c.pcd", cloud), 0);
  EXPECT_EQ(cloud.width, 640u);
  EXPECT_EQ(cloud.height, 480u);
  EXPECT_FALSE(cloud.is_dense);
  EXPECT_TRUE(std::isnan(cloud.at(0, 0).z));
  EXPECT_NEAR(cloud.at(320, 240).z, 1.5f, 1e-4f);
  EXPECT_NEAR(cloud.at(320, 240).x, 0.5f * 1.5f / 580.0f, 1e-5f);
}

TEST(FrameIo, WrongImageTypeIsRejected) {
  const std::string dir = testing::ScratchDir();
  cv::imwrite(dir + "/rgb.png", cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3)));
  try {
    ReadDepthPng(dir + "/rgb.png");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("single-channel 16-bit PNG"), std::string::npos);
  }
  testing::WriteText(dir + "/junk.png", "not an image");
  EXPECT_THROW(ReadDepthPng(dir + "/junk.png"), InputError);
  EXPECT_THROW(ReadDepthPng(dir + "/missing.png"), InputError);
}

TEST(FrameIo, PreviewHasEveryPanel) {
  const std::string dir = testing::ScratchDir();
  const DepthFrame ideal = BoxScene();
  const DepthFrame noisy =
      ApplyKinectNoise(ideal, CameraIntrinsics::KinectV1(), KinectNoiseOptions{}, 1);
  WritePreviewPng({{&ideal, PreviewPanel::Kind::kDepth, "ideal"},
                   {&noisy, PreviewPanel::Kind::kShadedDepth, "noisy"},
                   {&noisy, PreviewPanel::Kind::kIds, "ids"}},
                  2,
                  dir + "/p.png");
  const cv::Mat preview = cv::imread(dir + "/p.png");
  EXPECT_EQ(preview.cols, 1280);
  EXPECT_EQ(preview.rows, 2 * (480 + 26));
  EXPECT_THROW(WritePreviewPng({}, 2, dir + "/q.png"), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir + "/q.png"));
}

// Files that crashed PCL or took gigabytes (tests/data/crashers): one line
// naming the file and the rule, nothing allocated for what is not there.
TEST(FrameIo, CrashingCloudsAreOneLineErrors) {
  const std::string dir = FURN_SOURCE_DIR "/tests/data/crashers/";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"pcd_crash_seed1_run15.pcd", "COUNT of field z '4294967295' must be in 1..4096"},
      {"pcd_crash_seed1_run256.pcd", "COUNT of field x '65536' must be in 1..4096"},
      {"manual_pcd_bincomp_bad_usize.pcd", "uncompressed size 4294967280 must be POINTS"},
      {"manual_pcd_bincomp_zero.pcd", "uncompressed size 0 must be POINTS"},
      {"manual_pcd_huge_points_decl.pcd", "WIDTH, HEIGHT and POINTS must be whole numbers"},
      {"manual_ply_list_huge.ply", "vertex property x must be a scalar, not a list"},
      {"fuzz_pcd_garbage_first_line.pcd", "is neither a comment nor a PCD keyword"},
      {"fuzz_ply_vertex_list.ply", "vertex property vertex_indices must be a scalar, not a list"},
      {"asan_pcd_points_twice.pcd", "PCD header line POINTS appears twice"},
  };
  for (const auto& [file, rule] : cases) {
    const std::string error = testing::ErrorOf([&] { ReadPointCloudFile(dir + file); });
    EXPECT_NE(error.find(file), std::string::npos) << error;
    EXPECT_NE(error.find(rule), std::string::npos) << error;
  }
}

// The one decoder of packed points: every numeric type, row padding, and
// each broken layout a clear error.
TEST(PointFields, DecodesEveryTypeAndRowPaddingAndRefusesBrokenLayouts) {
  // Two rows of two points: x as int16, y as float64, z as uint8; 3 bytes of
  // padding per point (14 bytes), 4 per row.
  struct Point {
    int16_t x;
    double y;
    uint8_t z;
  };
  const int point_step = 14, row_step = 2 * point_step + 4;
  std::vector<uint8_t> data(2 * row_step, 0xEE);
  const Point points[4] = {{-3, 0.25, 7}, {5, -1.5, 0}, {100, 2.0, 255}, {0, 0.0, 1}};
  for (int k = 0; k < 4; ++k) {
    uint8_t* at = data.data() + (k / 2) * row_step + (k % 2) * point_step;
    std::memcpy(at, &points[k].x, 2);
    std::memcpy(at + 2, &points[k].y, 8);
    std::memcpy(at + 10, &points[k].z, 1);
  }
  PackedPoints packed;
  packed.data = data.data();
  packed.size = data.size();
  packed.width = 2;
  packed.height = 2;
  packed.point_step = point_step;
  packed.row_step = row_step;
  packed.fields = {{"x", 0, 3}, {"y", 2, 8}, {"z", 10, 2}, {"rgb", 11, 7}};
  const std::vector<Eigen::Vector3f> xyz = DecodeXyz(packed, "c.pcd");
  ASSERT_EQ(xyz.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(xyz[k], Eigen::Vector3f(points[k].x, static_cast<float>(points[k].y), points[k].z))
        << k;
  }
  auto error = [&](const PackedPoints& p) {
    return testing::ErrorOf([&] { DecodeXyz(p, "c.pcd"); });
  };
  PackedPoints broken = packed;
  broken.fields.erase(broken.fields.begin() + 1);
  EXPECT_NE(error(broken).find("c.pcd: the cloud has no x, y, z fields (no 'y')"),
            std::string::npos);
  broken = packed;
  broken.fields[0].datatype = 9;
  EXPECT_NE(error(broken).find("datatype 9"), std::string::npos);
  broken = packed;
  broken.fields[1].offset = 7;  // 8 bytes from 7 pass the 14-byte point
  EXPECT_NE(error(broken).find("lies outside point_step 14"), std::string::npos);
  broken = packed;
  broken.row_step = 20;
  EXPECT_NE(error(broken).find("row_step 20 is less than width x point_step"), std::string::npos);
  broken = packed;
  broken.size = data.size() - 1;
  EXPECT_NE(error(broken).find("shorter than its header declares"), std::string::npos);
  broken = packed;
  broken.width = broken.height = uint64_t{1} << 40;
  EXPECT_NE(error(broken).find("over the limit of 2^26"), std::string::npos);
  broken = packed;
  broken.big_endian = true;
  EXPECT_NE(error(broken).find("big-endian"), std::string::npos);
}

TEST(FrameIo, PcdAndPlyHeadersAreCheckedAgainstTheFile) {
  const std::string header =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4\nHEIGHT 1\n"
      "POINTS 4\n";
  auto error_of = [](const std::string& bytes) {
    return testing::ErrorOf([&] { CheckPcdHeader(bytes, "x.pcd"); });
  };
  EXPECT_EQ(error_of(header + "DATA binary\n" + std::string(48, '\0')), "(no error)");
  EXPECT_NE(error_of(header + "DATA binary\n" + std::string(47, '\0')).find("body has 47 bytes"),
            std::string::npos);
  EXPECT_NE(error_of(header + "DATA ascii\n1 2 3\n").find("declares 4 points"), std::string::npos);
  EXPECT_NE(error_of(header + "DATA xml\n").find("must be ascii, binary"), std::string::npos);
  // 20 digits overflow 64 bits: our line, not std::stoull's exception.
  EXPECT_NE(error_of("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH "
                     "99999999999999999999\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n")
                .find("must be whole numbers up to 2^30"),
            std::string::npos);
  EXPECT_NE(error_of("VERSION 0.7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\n"
                     "POINTS 1\nDATA ascii\n1 2 3\n")
                .find("one entry per field"),
            std::string::npos);
  EXPECT_NE(error_of("VERSION 0.7\nFIELDS x\nSIZE 2\nTYPE F\nWIDTH 1\nHEIGHT 1\nPOINTS 1\n"
                     "DATA ascii\n1\n")
                .find("F of size 4 or 8"),
            std::string::npos);
  EXPECT_NE(error_of("VERSION 0.7\nFIELDS x\nSIZE 4\nTYPE F\nWIDTH 2\nHEIGHT 2\nPOINTS 3\n"
                     "DATA ascii\n1\n2\n3\n")
                .find("must equal POINTS"),
            std::string::npos);
  std::string compressed = header + "DATA binary_compressed\n";
  const uint32_t sizes[2] = {4, 48};
  compressed.append(reinterpret_cast<const char*>(sizes), 8);
  EXPECT_NE(error_of(compressed).find("compressed size 4 exceeds"), std::string::npos);
  EXPECT_NE(error_of("VERSION 0.7\nFIELDS x\n").find("ends without a DATA line"),
            std::string::npos);

  auto ply_error = [](const std::string& bytes) {
    return testing::ErrorOf([&] { CheckPlyHeader(bytes, "x.ply"); });
  };
  const std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1000000\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n";
  EXPECT_NE(ply_error(ply + std::string(12, '\0')).find("declare at least 12000000 bytes"),
            std::string::npos);
  EXPECT_NE(ply_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n"
                      "1\n")
                .find("no x, y, z"),
            std::string::npos);
  EXPECT_NE(ply_error("ply\nformat ascii 1.0\nelement vertex 99999999999\nend_header\n")
                .find("count up to 2^30"),
            std::string::npos);
}

// Damaged depth images of any format: our one line, and nothing a library
// prints of its own (libpng, OpenCV's TIFF reader, libtiff).
TEST(FrameIo, DamagedDepthImagesPrintNothingButOurError) {
  const std::string dir = testing::ScratchDir();
  DepthFrame frame;
  frame.Resize(16, 12);
  for (float& z : frame.depth) z = 1.25f;
  const std::vector<uint8_t> png = EncodeDepthPng(frame);
  std::vector<uint8_t> tiff;
  cv::imencode(".tif", cv::Mat(12, 16, CV_16UC1, cv::Scalar(1250)), tiff);
  for (const auto& [name, bytes] :
       {std::pair{std::string("d.png"), png}, std::pair{std::string("d.tif"), tiff}}) {
    for (size_t k = 0; k < 40; ++k) {
      std::vector<uint8_t> damaged = bytes;
      const size_t at = 16 + (k * 7919u) % (damaged.size() - 16);
      damaged[at] = static_cast<uint8_t>(damaged[at] ^ (1 << (k % 8)));
      if (k % 5 == 4) damaged.resize(damaged.size() / 2);  // and some truncated
      testing::WriteText(dir + "/" + name, std::string(damaged.begin(), damaged.end()));
      ::testing::internal::CaptureStderr();
      std::string error;
      try {
        ReadDepthImage(dir + "/" + name, std::nullopt);
      } catch (const InputError& e) {
        error = e.what();
      }
      const std::string printed = ::testing::internal::GetCapturedStderr();
      EXPECT_EQ(printed, "") << name << " damaged at " << at;
      if (!error.empty()) {
        EXPECT_NE(error.find(name), std::string::npos) << error;
      }
    }
  }
}

}  // namespace
}  // namespace furn
