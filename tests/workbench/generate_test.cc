// Dataset generation end to end on the procedural catalog: ground truth,
// determinism, shards, resuming after a crash, and clear errors.
#include "workbench/pipelines/generate.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "core/util/error.h"
#include "db/dataset_db.h"
#include "renderers/embree_caster.h"
#include "scenes/procedural_catalog.h"
#include "tests/test_util.h"
#include "tests/workbench/dataset_dump.h"
#include "workbench/formats/depth_png.h"
#include "workbench/pipelines/dataset_tools.h"

namespace furn {
namespace {

GenerateOptions SmallRun(int rooms, uint64_t seed) {
  GenerateOptions options;
  options.catalog_spec = "procedural:2";
  options.rooms = rooms;
  options.seed = seed;
  options.room.frames_per_room = 2;
  options.room.max_side_m = 6;
  return options;
}

std::string Dump(const std::string& path) { return testing::DumpDataset(path); }

// One target in front of the camera, optionally half hidden by a wall panel.
std::vector<FrameObjectRecord> ViewOfSideboard(bool half_hidden) {
  RoomLayout layout;
  layout.width_m = layout.depth_m = 8;
  layout.wall_height_m = 2.6;
  std::map<std::string, std::shared_ptr<const TriangleMesh>> meshes;
  const ProceduralModel sideboard = MakeProceduralModel(FurnitureClass::kSideboard, 4);
  meshes["sideboard"] = std::make_shared<TriangleMesh>(sideboard.model.mesh);
  PlacedObject target;
  target.model_id = "sideboard";
  target.furniture_class = FurnitureClass::kSideboard;
  target.instance_id = kFirstObjectId;
  target.size_m = BoundingBox(sideboard.model.mesh).Size().cast<double>();
  layout.objects.push_back(target);
  if (half_hidden) {
    // A panel from x = -3 to x = 0 between the camera (at x = 0) and the target:
    // it hides exactly the target's left half in the image.
    TriangleMesh panel = MakeBox({-3.0f, -0.01f, 0.0f}, {0.0f, 0.01f, 2.0f});
    PlaceOnFloorCentred(&panel);
    meshes["panel"] = std::make_shared<TriangleMesh>(panel);
    PlacedObject occluder;
    occluder.model_id = "panel";
    occluder.instance_id = kFirstObjectId + 1;
    occluder.x = -1.5;
    occluder.y = -1.5;
    occluder.size_m = Eigen::Vector3d(3, 0.02, 2);
    layout.objects.push_back(occluder);
  }
  const Scene scene = BuildRoomScene(layout, meshes);
  const CameraIntrinsics camera = CameraIntrinsics::KinectV1();
  const Eigen::Isometry3d world_from_camera =
      LookAlong(Eigen::Vector3d(0, -3, 0.5), Eigen::Vector3d(0, 1, -0.05));
  EmbreeCaster caster;
  const DepthFrame ideal = caster.Render(scene, camera, world_from_camera);
  ObjectGroundTruth ground_truth(layout, scene);
  return ground_truth.Compute(ideal, camera, world_from_camera);
}

TEST(GroundTruth, UnoccludedObjectIsFullyVisible) {
  const std::vector<FrameObjectRecord> objects = ViewOfSideboard(false);
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_TRUE(objects[0].in_frustum);
  EXPECT_GT(objects[0].amodal_pixels, 10000);
  EXPECT_GT(objects[0].visibility, 0.98);
  EXPECT_EQ(objects[0].visible_box, objects[0].amodal_box);
}

TEST(GroundTruth, HalfHiddenObjectIsHalfVisible) {
  const std::vector<FrameObjectRecord> objects = ViewOfSideboard(true);
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_NEAR(objects[0].visibility, 0.5, 0.05);
  // The visible box is the right half: it starts at the image centre.
  EXPECT_NEAR(objects[0].visible_box[0], 319.5, 2);
  EXPECT_LT(objects[0].amodal_box[0], 250);
}

TEST(Generate, SameSeedSameDatabaseDifferentSeedDifferent) {
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  const GenerateSummary summary = GenerateDataset(catalog, SmallRun(3, 7), dir + "/a.db");
  EXPECT_EQ(summary.rooms_written, 3);
  EXPECT_EQ(summary.frames_written, 6);
  GenerateDataset(catalog, SmallRun(3, 7), dir + "/b.db");
  GenerateDataset(catalog, SmallRun(3, 8), dir + "/c.db");
  EXPECT_EQ(Dump(dir + "/a.db"), Dump(dir + "/b.db"));
  EXPECT_NE(Dump(dir + "/a.db"), Dump(dir + "/c.db"));
  // Running again resumes: nothing to do, nothing changes.
  const GenerateSummary again = GenerateDataset(catalog, SmallRun(3, 7), dir + "/a.db");
  EXPECT_EQ(again.rooms_written, 0);
  EXPECT_EQ(again.rooms_already_present, 3);
  EXPECT_EQ(Dump(dir + "/a.db"), Dump(dir + "/b.db"));
}

// OSMesa has one context, so its rooms render one after another (with Embree
// a room per core): same rows either way apart from the rendered pixels.
TEST(Generate, OsMesaRendererGeneratesEveryRoom) {
  const std::string dir = testing::ScratchDir();
  GenerateOptions options = SmallRun(3, 7);
  options.renderer = RendererKind::kOsMesa;
  const GenerateSummary summary =
      GenerateDataset(OpenCatalog("procedural:2"), options, dir + "/o.db");
  EXPECT_EQ(summary.workers, 1);
  EXPECT_EQ(summary.rooms_written, 3);
  EXPECT_EQ(summary.frames_written, 6);
  DatasetDb db(dir + "/o.db", DatasetDb::Mode::kReadOnly);
  EXPECT_EQ(db.RoomIds(), (std::vector<int64_t>{0, 1, 2}));
}

TEST(Generate, TwoShardsMergedEqualOneRun) {
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  GenerateOptions shard0 = SmallRun(5, 3), shard1 = SmallRun(5, 3);
  shard0.shard_count = shard1.shard_count = 2;
  shard1.shard_index = 1;
  EXPECT_EQ(GenerateDataset(catalog, shard0, dir + "/s0.db").rooms_written, 3);
  EXPECT_EQ(GenerateDataset(catalog, shard1, dir + "/s1.db").rooms_written, 2);
  GenerateDataset(catalog, SmallRun(5, 3), dir + "/all.db");
  const MergeSummary merged = MergeDatasets({dir + "/s0.db", dir + "/s1.db"}, dir + "/merged.db");
  EXPECT_EQ(merged.rooms, 5);
  EXPECT_EQ(Dump(dir + "/merged.db"), Dump(dir + "/all.db"));
  // Merging into an existing file, or datasets of other runs, is refused.
  EXPECT_THROW(MergeDatasets({dir + "/s0.db"}, dir + "/merged.db"), InputError);
  // A shard left out: refused naming the missing rooms, unless partial is allowed.
  EXPECT_EQ(testing::ErrorOf([&] { MergeDatasets({dir + "/s0.db"}, dir + "/half.db"); }),
            "the inputs hold 3 of the 5 rooms of their generation (missing room 1, 3: a shard "
            "left out, or one whose task did not finish); --allow-partial merges them anyway");
  EXPECT_FALSE(std::filesystem::exists(dir + "/half.db"));
  EXPECT_EQ(MergeDatasets({dir + "/s0.db"}, dir + "/half.db", /*allow_partial=*/true).rooms, 3);
  GenerateDataset(catalog, SmallRun(2, 99), dir + "/other.db");
  EXPECT_THROW(MergeDatasets({dir + "/s0.db", dir + "/other.db"}, dir + "/bad.db"), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.db"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.db.partial"));
}

TEST(Generate, KilledInsideARoomThenRerunEqualsAnUninterruptedRun) {
  const std::string dir = testing::ScratchDir();
  const std::string command =
      std::string(FURN_WORKBENCH_BINARY) +
      " generate --catalog procedural:2 --rooms 3 --frames 2 --max-side 6 --seed 11 --quiet";
  // The test hook ends the process inside room 1's transaction, as `kill -9` would.
  int status =
      std::system(("FURN_TEST_CRASH_IN_ROOM=1 " + command + " --out " + dir + "/crash.db").c_str());
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 3);
  {
    DatasetDb crashed(dir + "/crash.db", DatasetDb::Mode::kReadOnly);
    EXPECT_EQ(crashed.RoomIds(), std::vector<int64_t>{0});  // only whole rooms
  }
  status = std::system((command + " --out " + dir + "/crash.db > /dev/null").c_str());
  ASSERT_EQ(WEXITSTATUS(status), 0);
  status = std::system((command + " --out " + dir + "/clean.db > /dev/null").c_str());
  ASSERT_EQ(WEXITSTATUS(status), 0);
  EXPECT_EQ(Dump(dir + "/crash.db"), Dump(dir + "/clean.db"));
}

// How two datasets of the same run differ, frame by frame.
struct FrameDifferences {
  int64_t pixels = 0;
  int64_t depth_differs = 0;       // ideal or noisy depth, any amount
  int64_t depth_over_1mm = 0;      // by more than 1 mm
  int64_t return_differs = 0;      // a return in one, none in the other
  int64_t ids_differ = 0;          // ideal or noisy instance ids
  int64_t visibility_differs = 0;  // frame_objects rows whose pixel counts differ
  int64_t rows_differ = 0;         // other rows (layout, poses, objects)
};

FrameDifferences CompareFrames(const std::string& a_path, const std::string& b_path) {
  DatasetDb a(a_path, DatasetDb::Mode::kReadOnly), b(b_path, DatasetDb::Mode::kReadOnly);
  FrameDifferences d;
  if (a.RoomIds() != b.RoomIds()) ++d.rows_differ;
  for (int64_t room_id : a.RoomIds()) {
    const RoomRecord ra = a.ReadRoom(room_id, true), rb = b.ReadRoom(room_id, true);
    if (ra.objects.size() != rb.objects.size() || ra.frames.size() != rb.frames.size()) {
      ++d.rows_differ;
      continue;
    }
    for (size_t o = 0; o < ra.objects.size(); ++o) {
      d.rows_differ += ra.objects[o].x != rb.objects[o].x ||
                       ra.objects[o].yaw != rb.objects[o].yaw ||
                       ra.objects[o].model_id != rb.objects[o].model_id;
    }
    for (size_t f = 0; f < ra.frames.size(); ++f) {
      const FrameRecord& fa = ra.frames[f];
      const FrameRecord& fb = rb.frames[f];
      d.rows_differ += !fa.world_from_camera.isApprox(fb.world_from_camera, 0);
      for (bool noisy : {false, true}) {
        DepthFrame da = DecodeDepthPng(noisy ? fa.depth_noisy_png : fa.depth_ideal_png, "a");
        DepthFrame db = DecodeDepthPng(noisy ? fb.depth_noisy_png : fb.depth_ideal_png, "b");
        DecodeIdPng(noisy ? fa.ids_noisy_png : fa.ids_png, "a", &da);
        DecodeIdPng(noisy ? fb.ids_noisy_png : fb.ids_png, "b", &db);
        for (size_t i = 0; i < da.depth.size(); ++i) {
          ++d.pixels;
          d.depth_differs += da.depth[i] != db.depth[i];
          d.depth_over_1mm += std::abs(da.depth[i] - db.depth[i]) > 0.0011f;
          d.return_differs += (da.depth[i] > 0) != (db.depth[i] > 0);
          d.ids_differ += da.instance_ids[i] != db.instance_ids[i];
        }
      }
      for (size_t o = 0; o < std::min(fa.objects.size(), fb.objects.size()); ++o) {
        d.visibility_differs += fa.objects[o].visible_pixels != fb.objects[o].visible_pixels ||
                                fa.objects[o].amodal_pixels != fb.objects[o].amodal_pixels;
      }
      d.rows_differ += fa.objects.size() != fb.objects.size();
    }
  }
  return d;
}

// Embree's kernels differ per ISA (AVX-512 runs 16-wide packets, AVX2 splits
// them into 8-wide ones and reads every lane, SSE4.2 is 4-wide, and only
// AVX2 and up use FMA), so hit distances can differ in the last float bit
// between CPUs. The same seed must give the same rooms, cameras and objects
// everywhere, and frames equal within that rounding. Each ISA runs in its own
// process, since the Embree device is made once per process.
TEST(Generate, FramesAgreeOnEveryEmbreeIsa) {
  if (!EmbreeDeviceConfig().empty()) GTEST_SKIP() << "compares ISAs itself";
  const std::string dir = testing::ScratchDir();
  std::vector<std::string> configs = {""};
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2")) configs.push_back("isa=avx2");
  configs.push_back("isa=sse4.2");
  std::vector<std::string> dbs;
  for (const std::string& config : configs) {
    dbs.push_back(dir + "/" + (config.empty() ? "native" : config.substr(4)) + ".db");
    const testing::CommandResult run =
        testing::RunCommand("FURN_EMBREE_CONFIG='" + config +
                            "' " FURN_WORKBENCH_BINARY
                            " generate --catalog procedural:2 --rooms 3 --frames 2 --max-side 6"
                            " --seed 21 --quiet --out " +
                            dbs.back());
    ASSERT_EQ(run.exit_code, 0) << config << ": " << run.output;
  }
  for (size_t k = 1; k < dbs.size(); ++k) {
    const FrameDifferences d = CompareFrames(dbs[0], dbs[k]);
    std::printf(
        "%s against the CPU's own ISA: of %lld pixel values, depth differs in %lld "
        "(by over 1 mm in %lld), a return in %lld, the id in %lld; visibility rows %lld\n",
        configs[k].c_str(),
        static_cast<long long>(d.pixels),
        static_cast<long long>(d.depth_differs),
        static_cast<long long>(d.depth_over_1mm),
        static_cast<long long>(d.return_differs),
        static_cast<long long>(d.ids_differ),
        static_cast<long long>(d.visibility_differs));
    // Measured on 3 rooms x 2 frames (ideal and noisy): 30 (AVX2) and 95
    // (SSE4.2) of 3.7 M depth values differ, 1 and 11 by a disparity step;
    // ids and returns identical. The tolerance is 10x that.
    EXPECT_EQ(d.rows_differ, 0) << configs[k];
    EXPECT_LE(d.depth_differs, d.pixels / 1000) << configs[k];
    EXPECT_LE(d.depth_over_1mm, d.pixels / 20000) << configs[k];
    EXPECT_LE(d.return_differs + d.ids_differ, d.pixels / 100000) << configs[k];
    EXPECT_LE(d.visibility_differs, 1) << configs[k];
  }
  // A config Embree cannot use is one clear line, not a crash, and no file.
  for (const char* config : {"isa=avx3", "threads=x"}) {
    const testing::CommandResult bad =
        testing::RunCommand(std::string("FURN_EMBREE_CONFIG='") + config +
                            "' " FURN_WORKBENCH_BINARY
                            " generate --catalog procedural:2 --rooms 1 --frames 1 --quiet --out " +
                            dir + "/bad.db");
    EXPECT_EQ(bad.exit_code, 1) << bad.output;
    EXPECT_NE(bad.output.find(std::string("FURN_EMBREE_CONFIG='") + config + "'"),
              std::string::npos)
        << bad.output;
    // One line besides the catalog's warning (procedural catalogs offer no clutter).
    int lines = 0;
    std::istringstream output(bad.output);
    for (std::string line; std::getline(output, line);) lines += line.rfind("warning: ", 0) != 0;
    EXPECT_EQ(lines, 1) << bad.output;
    EXPECT_FALSE(std::filesystem::exists(dir + "/bad.db")) << config;
  }
}

TEST(Generate, InfoPreviewAndExportDescribeTheDataset) {
  const std::string dir = testing::ScratchDir();
  GenerateDataset(OpenCatalog("procedural:2"), SmallRun(4, 5), dir + "/d.db");
  const DatasetInfo info = ReadDatasetInfo(dir + "/d.db");
  int rooms = 0;
  for (const auto& [split, count] : info.rooms_per_split) rooms += count;
  EXPECT_EQ(rooms, 4);
  EXPECT_EQ(info.frames, 8);
  int64_t views = 0, histogram = 0;
  for (const auto& [name, count] : info.views_per_class) views += count;
  for (int64_t count : info.visibility_histogram) histogram += count;
  EXPECT_GT(views, 0);
  EXPECT_EQ(views, histogram);
  EXPECT_NE(DatasetInfoText(info).find("8 frames"), std::string::npos);
  WriteDatasetPreview(dir + "/d.db", 4, dir + "/sheet.png");
  const cv::Mat sheet = cv::imread(dir + "/sheet.png");
  EXPECT_EQ(sheet.cols, 4 * 320);
  EXPECT_EQ(sheet.rows, 240);
  EXPECT_EQ(ExportDataset(dir + "/d.db", "bop", dir + "/bop"), 8);
  EXPECT_EQ(ExportDataset(dir + "/d.db", "pcd", dir + "/pcd"), 8);
  EXPECT_TRUE(std::filesystem::exists(dir + "/bop/models/models_info.json"));
  EXPECT_THROW(ExportDataset(dir + "/d.db", "obj", dir + "/x"), InputError);
}

TEST(Generate, BadInputsAreRejectedClearly) {
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  GenerateDataset(catalog, SmallRun(1, 5), dir + "/d.db");
  GenerateOptions other = SmallRun(1, 5);
  other.room.frames_per_room = 3;
  try {
    GenerateDataset(catalog, other, dir + "/d.db");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("/room/frames_per_room"), std::string::npos)
        << error.what();
  }
  // A dataset from a newer build is refused.
  {
    Database db(dir + "/d.db");
    db.Execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'");
  }
  EXPECT_THROW(DatasetDb(dir + "/d.db", DatasetDb::Mode::kReadOnly), DbError);
  testing::WriteText(dir + "/junk.db", std::string(5000, 'x'));
  EXPECT_THROW(DatasetDb(dir + "/junk.db", DatasetDb::Mode::kReadOnly), DbError);
  EXPECT_THROW(GenerateDataset(catalog, SmallRun(1, 5), "/nonexistent/dir/d.db"), DbError);
  EXPECT_THROW(ParseShard("2/2"), InputError);
  EXPECT_THROW(ParseShard("a/b"), InputError);
  EXPECT_EQ(ParseShard("1/4"), std::make_pair(1, 4));
  GenerateOptions bad = SmallRun(0, 1);
  EXPECT_THROW(GenerateDataset(catalog, bad, dir + "/e.db"), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir + "/e.db"));
  EXPECT_THROW(ReadDatasetInfo(dir + "/missing.db"), InputError);
}

}  // namespace
}  // namespace furn
