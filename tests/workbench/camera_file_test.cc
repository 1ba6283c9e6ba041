// Camera files as datasets ship them (BOP, ROS), poses as people type them,
// and the cloud and depth-image formats real sensors' tools write.
#include "workbench/formats/camera_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "core/geometry/render_compare.h"
#include "core/util/error.h"
#include "tests/test_util.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/point_cloud_file.h"
#include "workbench/formats/scan_inputs.h"

namespace furn {
namespace {

TEST(CameraFile, BopCameraAndSceneCameraAndRosCameraInfo) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/camera.json",
                     R"({"cx": 325.26, "cy": 242.05, "depth_scale": 0.1, "fx": 572.4,
                         "fy": 573.57, "height": 480, "width": 640})");
  const CameraFile bop = ReadCameraFile(dir + "/camera.json");
  EXPECT_DOUBLE_EQ(bop.camera.fx, 572.4);
  EXPECT_DOUBLE_EQ(bop.camera.cy, 242.05);
  EXPECT_EQ(bop.camera.width, 640);
  ASSERT_TRUE(bop.units_per_metre.has_value());
  EXPECT_DOUBLE_EQ(*bop.units_per_metre, 10000);  // 0.1 mm per unit

  testing::WriteText(dir + "/scene_camera.json",
                     R"({"0": {"cam_K": [500, 0, 320, 0, 501, 240, 0, 0, 1], "depth_scale": 1.0},
                         "12": {"cam_K": [600, 0, 300, 0, 601, 200, 0, 0, 1], "depth_scale": 0.5}})");
  const CameraFile scene = ReadCameraFile(dir + "/scene_camera.json", 12);
  EXPECT_DOUBLE_EQ(scene.camera.fx, 600);
  EXPECT_DOUBLE_EQ(scene.camera.fy, 601);
  EXPECT_DOUBLE_EQ(scene.camera.cy, 200);
  EXPECT_EQ(scene.camera.width, 0);  // the image's size applies
  EXPECT_DOUBLE_EQ(*scene.units_per_metre, 2000);
  EXPECT_NE(testing::ErrorOf([&] {
              ReadCameraFile(dir + "/scene_camera.json", 5);
            }).find("no camera for image 5"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] {
              ReadCameraFile(dir + "/scene_camera.json");
            }).find("needs the image id"),
            std::string::npos);

  // camera_calibration's YAML, and a `rostopic echo` dump of a CameraInfo.
  testing::WriteText(dir + "/calib.yaml",
                     "image_width: 640\nimage_height: 480\ncamera_name: depth\n"
                     "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [570.3, 0, 319.5, 0, 570.3, "
                     "239.5, 0, 0, 1]\ndistortion_model: plumb_bob\n");
  const CameraFile calibration = ReadCameraFile(dir + "/calib.yaml");
  EXPECT_DOUBLE_EQ(calibration.camera.fx, 570.3);
  EXPECT_EQ(calibration.camera.height, 480);
  EXPECT_FALSE(calibration.units_per_metre.has_value());
  testing::WriteText(dir + "/info.yaml",
                     "header:\n  seq: 4\n  frame_id: camera_depth_optical_frame\nheight: 480\n"
                     "width: 640\ndistortion_model: plumb_bob\nD: [0.0, 0.0, 0.0, 0.0, 0.0]\n"
                     "K: [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0]\n---\n");
  const CameraFile info = ReadCameraFile(dir + "/info.yaml");
  EXPECT_DOUBLE_EQ(info.camera.fx, 525);
  EXPECT_EQ(info.camera.width, 640);

  // Bad files: one line naming the file and the key.
  testing::WriteText(dir + "/skewed.yaml", "K: [525, 3, 319.5, 0, 525, 239.5, 0, 0, 1]\n");
  EXPECT_NE(testing::ErrorOf([&] {
              ReadCameraFile(dir + "/skewed.yaml");
            }).find("must be [fx, 0, cx, 0, fy, cy, 0, 0, 1]"),
            std::string::npos);
  testing::WriteText(dir + "/other.yaml", "name: not a camera\n");
  EXPECT_NE(testing::ErrorOf([&] {
              ReadCameraFile(dir + "/other.yaml");
            }).find("other.yaml: not a camera file"),
            std::string::npos);
  testing::WriteText(dir + "/text.json", R"({"fx": "525"})");
  EXPECT_NE(
      testing::ErrorOf([&] { ReadCameraFile(dir + "/text.json"); }).find("'fx' must be a number"),
      std::string::npos);
  testing::WriteText(dir + "/broken.json", "{\"fx\": ");
  EXPECT_NE(testing::ErrorOf([&] { ReadCameraFile(dir + "/broken.json"); }).find("not valid JSON"),
            std::string::npos);
  testing::WriteText(dir + "/negative.json",
                     R"({"fx": -5, "fy": 5, "cx": 1, "cy": 1, "width": 4, "height": 4})");
  EXPECT_NE(testing::ErrorOf([&] { ReadCameraFile(dir + "/negative.json"); }).find("negative.json"),
            std::string::npos);
}

// Hostile camera files (issue 29): each one line naming the file and the
// rule, no huge allocation, no misleading number.
TEST(CameraFile, HostileFilesAreOneLineNamingTheFileAndTheRule) {
  const std::string dir = testing::ScratchDir();
  const struct {
    const char* name;
    std::string text;
    const char* message;
  } cases[] = {
      {"scalar.yaml", "camera_matrix: 5\n", "scalar.yaml: camera_matrix has no data list"},
      {"scalar_k.yaml", "K: {a: 1}\n", "scalar_k.yaml: K must be a list of numbers"},
      {"no_fx.json", R"({"fy": 500, "cx": 320, "cy": 240})", "no_fx.json: 'fx' must be a number"},
      {"wide.json",
       R"({"fx": 500, "fy": 500, "cx": 320, "cy": 240, "width": 1e20})",
       "wide.json: 'width' must be a whole number in 1..16384"},
      {"tiny_f.json",
       R"({"fx": 1e-300, "fy": 500, "cx": 320, "cy": 240})",
       "must be at least 1 pixel"},
      {"scale_small.json",
       R"({"fx": 500, "fy": 500, "cx": 320, "cy": 240, "depth_scale": 1e300})",
       "scale_small.json: depth_scale gives 1e-297 depth units per metre"},
      {"scale_big.json",
       R"({"fx": 500, "fy": 500, "cx": 320, "cy": 240, "depth_scale": 1e-300})",
       "scale_big.json: depth_scale gives 1e+303 depth units per metre"},
      {"skew.yaml", "K: [500, 3, 320, 0, 500, 240, 0, 0, 1]\n", "(no skew)"},
      {"big.yaml", "K: [" + std::string(2 << 20, ' ') + "]\n", "big.yaml: a camera file of"},
      // yaml-cpp 0.7's LoadAll looped forever on a document starting with ','
      // (found by the fuzzer): only the first document is parsed, by Load.
      {"comma.yaml", ", 0.0, 1.0], 1.0]\n", "comma.yaml: not a camera file"},
  };
  for (const auto& c : cases) {
    testing::WriteText(dir + "/" + c.name, c.text);
    const std::string error = testing::ErrorOf([&] { ReadCameraFile(dir + "/" + c.name); });
    EXPECT_NE(error.find(c.message), std::string::npos) << c.name << ": " << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
  testing::WriteText(dir + "/two.yaml",
                     "K: [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0]\n---\n, 1.0], 1]\n");
  EXPECT_DOUBLE_EQ(ReadCameraFile(dir + "/two.yaml").camera.fx, 525);
  EXPECT_NE(testing::ErrorOf([] {
              CameraFromMatrix({500, 0, 320, 0, 500, 240, 0, 0, 1}, 640, 1 << 30, "info K");
            }).find("info K: camera height"),
            std::string::npos);
}

TEST(CameraFile, PosesAsMatricesOrTranslationAndQuaternion) {
  const Eigen::Isometry3d a = ParsePose("t=1,2,3 q=0,0,0,1", "--pose");
  EXPECT_TRUE(a.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE(a.linear().isApprox(Eigen::Matrix3d::Identity()));
  // 90 degrees about z, as a quaternion x,y,z,w (parts in either order,
  // apart by ';' too) and as a matrix row by row.
  const std::string h = std::to_string(std::sqrt(0.5));
  const Eigen::Isometry3d q = ParsePose("t=0,0,1.5 q=0,0," + h + "," + h, "--pose");
  const Eigen::Isometry3d swapped = ParsePose("q=0,0," + h + "," + h + ";t=0,0,1.5", "--pose");
  const Eigen::Isometry3d m = ParsePose("0,-1,0,0, 1,0,0,0, 0,0,1,1.5, 0,0,0,1", "--pose");
  EXPECT_TRUE(q.matrix().isApprox(m.matrix(), 1e-5));
  EXPECT_TRUE(swapped.matrix().isApprox(m.matrix(), 1e-5));
  // x,y,z,w is Eigen's coeffs() order.
  EXPECT_TRUE(Eigen::Quaterniond(q.linear())
                  .coeffs()
                  .isApprox(Eigen::Vector4d(0, 0, std::sqrt(0.5), std::sqrt(0.5)), 1e-5));
  // Seven bare numbers (the old x,y,z,qw,qx,qy,qz) are refused, naming the
  // form to give.
  const std::string old =
      testing::ErrorOf([] { ParsePose("0,0,1.5,0.5,-0.5,0.5,-0.5", "--pose"); });
  EXPECT_NE(old.find("seven bare numbers are not read"), std::string::npos) << old;
  EXPECT_NE(old.find("'t=x,y,z q=qx,qy,qz,qw'"), std::string::npos) << old;
  EXPECT_NE(testing::ErrorOf([] { ParsePose("t=1,2 q=0,0,0,1", "--pose"); }).find("t= with 3"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([] { ParsePose("t=1,2,3 r=0,0,0,1", "--pose"); }).find("'r=0,0,0,1'"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([] {
              ParsePose("t=1,2,3 t=1,2,3 q=0,0,0,1", "--pose");
            }).find("is not one t=... or q=..."),
            std::string::npos);
  EXPECT_TRUE((m * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d(0, 1, 1.5)));
  EXPECT_NE(testing::ErrorOf([] { ParsePose("1,2,3", "--pose"); }).find("16 numbers"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([] { ParsePose("t=1,2,3 q=2,0,0,0", "--pose"); }).find("unit length"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([] {
              ParsePose("2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1", "--pose");
            }).find("not a rigid transform"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([] { ParsePose("t=1,x,3 q=0,0,0,1", "--pose"); }).find("'x'"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([] {
              ParsePose("1,inf,3,1,0,0,0,0,1,0,0,0,0,1,0,0", "--pose");
            }).find("not a finite number"),
            std::string::npos);
  EXPECT_TRUE(ParsePosition("1, 2, 3", "--sensor").isApprox(Eigen::Vector3d(1, 2, 3)));
}

TEST(RealScans, CameraOfAnOrganisedWorldCloudIsRecovered) {
  // A room-like set of surfaces seen by a 525-pixel camera at (1, -2, 1.3)
  // looking along +y, pitched down, in a floor-aligned world.
  const double fx = 525, fy = 524, cx = 319.5, cy = 239.5;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const double pitch = 0.5;
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(1, 0, 0);
  r.col(2) = Eigen::Vector3d(0, std::cos(pitch), -std::sin(pitch));
  r.col(1) = r.col(2).cross(r.col(0));
  pose.linear() = r;
  pose.translation() = Eigen::Vector3d(1, -2, 1.3);
  std::vector<Eigen::Vector3f> points(640 * 480, Eigen::Vector3f::Constant(NAN));
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d ray = r * Eigen::Vector3d((u - cx) / fx, (v - cy) / fy, 1);
      // The floor (z = 0) or a wall at y = 2, whichever comes first.
      double t = ray.z() < 0 ? -pose.translation().z() / ray.z() : 1e9;
      if (ray.y() > 0) t = std::min(t, (2 - pose.translation().y()) / ray.y());
      if (t < 8 && (u + v) % 7 != 0)
        points[static_cast<size_t>(v) * 640 + u] = (pose.translation() + t * ray).cast<float>();
    }
  }
  const std::optional<OrganisedCloudCamera> camera = CameraOfOrganisedCloud(points, 640, 480);
  ASSERT_TRUE(camera.has_value());
  EXPECT_NEAR(camera->intrinsics.fx, fx, 0.5);
  EXPECT_NEAR(camera->intrinsics.fy, fy, 0.5);
  EXPECT_NEAR(camera->intrinsics.cx, cx, 0.5);
  EXPECT_NEAR(camera->intrinsics.cy, cy, 0.5);
  EXPECT_LT((camera->world_from_camera.translation() - pose.translation()).norm(), 0.005);
  EXPECT_LT(Eigen::AngleAxisd(camera->world_from_camera.linear().transpose() * r).angle(), 0.002);
  // A cloud whose rows are not a camera's pixels: no camera.
  std::vector<Eigen::Vector3f> shuffled = points;
  std::reverse(shuffled.begin(), shuffled.begin() + 640 * 200);
  EXPECT_FALSE(CameraOfOrganisedCloud(shuffled, 640, 480).has_value());
  EXPECT_FALSE(CameraOfOrganisedCloud(points, 320, 480).has_value());
}

TEST(RealScans, DoubleAndIntegerFieldsAndViewpointAreRead) {
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/double.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double "
                     "y\nproperty double z\nend_header\n0.5 -0.25 2.125\n1 2 3\n-1 0 4.5\n");
  const ScanCloud ply = ReadPointCloudFile(dir + "/double.ply");
  ASSERT_EQ(ply.points.size(), 3u);
  EXPECT_TRUE(ply.points[0].isApprox(Eigen::Vector3f(0.5f, -0.25f, 2.125f)));
  EXPECT_TRUE(ply.points[2].isApprox(Eigen::Vector3f(-1, 0, 4.5f)));
  EXPECT_FALSE(ply.viewpoint.has_value());
  testing::WriteText(dir + "/double.pcd",
                     "VERSION 0.7\nFIELDS x y z rgb\nSIZE 8 8 8 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
                     "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0.5 1 1.4 0.7071068 0 0 0.7071068\nPOINTS 2\n"
                     "DATA ascii\n1.5 2.5 0.75 4.2e-39\n-3 4 1 0\n");
  const ScanCloud pcd = ReadPointCloudFile(dir + "/double.pcd");
  ASSERT_EQ(pcd.points.size(), 2u);
  EXPECT_TRUE(pcd.points[0].isApprox(Eigen::Vector3f(1.5f, 2.5f, 0.75f)));
  ASSERT_TRUE(pcd.viewpoint.has_value());
  EXPECT_TRUE(pcd.viewpoint->translation().isApprox(Eigen::Vector3d(0.5, 1, 1.4), 1e-6));
  EXPECT_TRUE((pcd.viewpoint->linear() * Eigen::Vector3d::UnitX())
                  .isApprox(Eigen::Vector3d::UnitY(), 1e-5));
  testing::WriteText(dir + "/int.pcd",
                     "VERSION 0.7\nFIELDS x y z\nSIZE 2 2 2\nTYPE I I I\nCOUNT 1 1 1\nWIDTH 1\n"
                     "HEIGHT 1\nPOINTS 1\nDATA ascii\n-2 3 7\n");
  EXPECT_TRUE(ReadPointCloudFile(dir + "/int.pcd").points[0].isApprox(Eigen::Vector3f(-2, 3, 7)));
}

TEST(RealScans, FloatTiffAndExrDepthImagesInMetres) {
  const std::string dir = testing::ScratchDir();
  cv::Mat metres(48, 64, CV_32F, cv::Scalar(0));
  for (int v = 0; v < 48; ++v) {
    for (int u = 0; u < 64; ++u) metres.at<float>(v, u) = (u + v) % 5 == 0 ? 0.f : 0.5f + 0.01f * u;
  }
  metres.at<float>(3, 3) = NAN;
  setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 0);
  ASSERT_TRUE(cv::imwrite(dir + "/depth.tiff", metres));
  ASSERT_TRUE(cv::imwrite(dir + "/depth.exr", metres));
  for (const char* name : {"/depth.tiff", "/depth.exr"}) {
    const DepthFrame frame = ReadDepthImage(dir + name, std::nullopt);
    ASSERT_EQ(frame.width, 64) << name;
    EXPECT_FLOAT_EQ(frame.DepthAt(10, 1), 0.6f) << name;
    EXPECT_EQ(frame.DepthAt(4, 1), 0.f) << name;  // no return stays none
    EXPECT_EQ(frame.DepthAt(3, 3), 0.f) << name;  // NaN: no return
    // A scale given applies: units per metre.
    EXPECT_FLOAT_EQ(ReadDepthImage(dir + name, 1000.0).DepthAt(10, 1), 0.0006f) << name;
  }
  // 16-bit TIFF defaults to millimetres.
  cv::Mat millimetres(48, 64, CV_16U, cv::Scalar(1500));
  ASSERT_TRUE(cv::imwrite(dir + "/depth16.tif", millimetres));
  EXPECT_FLOAT_EQ(ReadDepthImage(dir + "/depth16.tif", std::nullopt).DepthAt(5, 5), 1.5f);
  // Colour, another format, a broken file: one line each.
  ASSERT_TRUE(cv::imwrite(dir + "/colour.tiff", cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3))));
  EXPECT_NE(testing::ErrorOf([&] {
              ReadDepthImage(dir + "/colour.tiff", std::nullopt);
            }).find("one channel"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] {
              ReadDepthImage(dir + "/depth.jpg", std::nullopt);
            }).find(".exr (float)"),
            std::string::npos);
  testing::WriteText(dir + "/broken.exr", "not an image");
  EXPECT_NE(testing::ErrorOf([&] {
              ReadDepthImage(dir + "/broken.exr", std::nullopt);
            }).find("broken.exr: not a readable exr image"),
            std::string::npos);
}

// A TUM list line naming a folder or a file of another kind is that scan's
// own failure, not the batch's (issue 29): it expands to a depth source.
TEST(ScanInputs, TumListLinesOfOtherKindsStayScansOfTheirOwn) {
  const std::string dir = testing::ScratchDir();
  std::filesystem::create_directories(dir + "/depth/folder.png");
  testing::WriteText(dir + "/depth.txt",
                     "# timestamp filename\n1.0 depth/a.png\n2.0 depth/folder.png\n3.0 list.txt\n");
  const std::vector<ScanSource> sources =
      ExpandScanInputs({dir + "/depth.txt"}, ScanSource{}, false, false);
  ASSERT_EQ(sources.size(), 3u);
  EXPECT_EQ(sources[1].depth_path, dir + "/depth/folder.png");
  EXPECT_EQ(sources[2].depth_path, dir + "/list.txt");
  EXPECT_NE(testing::ErrorOf([&] { LoadScan(sources[1]); }).find("folder.png"), std::string::npos);
}

}  // namespace
}  // namespace furn
