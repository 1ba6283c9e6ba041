// The workbench binary as a user runs it: exit codes, one-line errors, outputs.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/geometry/mesh.h"
#include "core/util/error.h"
#include "core/util/file_util.h"
#include "db/dataset_db.h"
#include "scenes/mesh_io.h"
#include "tests/scenes/fixtures.h"
#include "tests/test_util.h"
#include "workbench/formats/depth_png.h"
#include "workbench/formats/point_cloud_file.h"
#include "workbench/pipelines/catalog_tools.h"

namespace furn {
namespace {

using RunResult = testing::CommandResult;

RunResult RunWorkbench(const std::string& arguments) {
  return testing::RunCommand(std::string(FURN_WORKBENCH_BINARY) + " " + arguments);
}

// Lines that are not catalog warnings (the test catalog has one bad entry).
size_t CountErrorLines(const std::string& text) {
  size_t lines = 0;
  std::istringstream stream(text);
  for (std::string line; std::getline(stream, line);) lines += line.rfind("warning: ", 0) != 0;
  return lines;
}

TEST(Cli, ListsTheProceduralCatalogAsTableAndJson) {
  const RunResult table = RunWorkbench("catalog list --catalog procedural:3 --load --quiet");
  ASSERT_EQ(table.exit_code, 0) << table.output;
  EXPECT_NE(table.output.find("procedural/chair-0"), std::string::npos);
  EXPECT_NE(table.output.find("16 entries in catalog procedural:3: 4 armchair "
                              "4 chair 4 sideboard 4 table; "
                              "16 models loaded"),
            std::string::npos)
      << table.output;
  const RunResult json =
      RunWorkbench("catalog list --catalog procedural:3 --json --class table --quiet");
  ASSERT_EQ(json.exit_code, 0) << json.output;
  const auto document = nlohmann::json::parse(json.output);
  ASSERT_EQ(document["entries"].size(), 4u);
  EXPECT_EQ(document["entries"][0]["class"], "table");
  EXPECT_GT(document["entries"][0]["size_m"]["height"].get<double>(), 0.69);
}

TEST(Cli, ShowAndExportAnSh3fEntry) {
  const std::string dir = testing::ScratchDir();
  const std::string catalog = testing::WriteTestSh3f(dir, "Test.sh3f");
  const RunResult show = RunWorkbench("catalog show Test/marker --catalog " + catalog);
  ASSERT_EQ(show.exit_code, 0) << show.output;
  EXPECT_NE(show.output.find("mesh size:     0.40x0.60x1.00 m"), std::string::npos) << show.output;
  EXPECT_NE(show.output.find("triangles:     24"), std::string::npos) << show.output;
  const RunResult exported = RunWorkbench("catalog export Test/marker --catalog " + catalog +
                                          " --out " + dir + "/marker.ply");
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  testing::ExpectMarkerPose(
      LoadMeshFile(dir + "/marker.ply").mesh, Eigen::Vector3f(0.4f, 0.6f, 1.0f), 1e-5f);
}

TEST(Cli, SheetWritesAPng) {
  const std::string dir = testing::ScratchDir();
  const RunResult sheet =
      RunWorkbench("catalog sheet --catalog procedural --quiet --out " + dir + "/s.png");
  ASSERT_EQ(sheet.exit_code, 0) << sheet.output;
  EXPECT_GT(std::filesystem::file_size(dir + "/s.png"), 10000u);
  // With the shape variety the vote network may train on, real sizes.
  const RunResult varied = RunWorkbench(
      "catalog sheet --catalog procedural --class table --shape-variety 5 --shape-sizes real "
      "--quiet --out " +
      dir + "/v.png");
  ASSERT_EQ(varied.exit_code, 0) << varied.output;
  EXPECT_NE(varied.output.find("models"), std::string::npos) << varied.output;
  EXPECT_GT(std::filesystem::file_size(dir + "/v.png"), 10000u);
}

TEST(Cli, UserMistakesGiveOneLineAndNonZeroExit) {
  const std::string dir = testing::ScratchDir();
  const std::string catalog = testing::WriteTestSh3f(dir, "Test.sh3f");
  struct Case {
    std::string arguments;
    std::string expected;
  };
  const Case cases[] = {
      {"catalog show Test/nope --catalog " + catalog, "entry 'Test/nope' is not in catalog"},
      {"catalog list --catalog /nonexistent/x.sh3f", "/nonexistent/x.sh3f: file does not exist"},
      {"catalog list --catalog bogus", "unknown catalog 'bogus'"},
      {"catalog list --catalog procedural --class stool", "unknown class 'stool'"},
      {"catalog export Test/marker --catalog " + catalog + " --out " + dir + "/m.xyz",
       "cannot export format 'xyz'"},
      {"catalog show Test/missing --catalog " + catalog, "missing/missing.obj: no such entry"},
  };
  for (const Case& c : cases) {
    const RunResult result = RunWorkbench(c.arguments);
    EXPECT_EQ(result.exit_code, 1) << c.arguments;
    EXPECT_EQ(CountErrorLines(result.output), 1u) << result.output;
    EXPECT_NE(result.output.find(c.expected), std::string::npos) << result.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.xyz"));
}

// Mesh headers whose counts the file cannot hold (issue 29): an OFF claiming
// 10^7 vertices and faces aborted assimp; now the entry is skipped with a
// warning naming the rule, and showing it is one error line, in little
// memory and time. ASCII PLY and binary STL counts likewise.
TEST(Cli, MeshHeadersThatLieAboutTheirCountsAreOneLine) {
  const std::string map = FURN_SOURCE_DIR "/tests/data/crashers/bags_meshes/off_count_lie_map.json";
  const RunResult show =
      testing::RunCommand("ulimit -v 2000000; timeout 10 " + std::string(FURN_WORKBENCH_BINARY) +
                          " catalog show c1 --catalog " + map);
  EXPECT_GT(show.exit_code, 0);
  EXPECT_LT(show.exit_code, 124) << "a signal or the timeout";
  EXPECT_NE(show.output.find("declares 10000000 vertices, more than its"), std::string::npos)
      << show.output;
  const std::string dir = testing::ScratchDir();
  testing::WriteText(dir + "/lie.ply",
                     "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 10000000\nproperty list uchar int "
                     "vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  std::string stl(84, '\0');
  stl[80] = '\x10';  // 2^28 + 16 triangles in 84 bytes
  stl[83] = '\x10';
  testing::WriteText(dir + "/lie.stl", stl);
  for (const char* file : {"/lie.ply", "/lie.stl"}) {
    EXPECT_NE(testing::ErrorOf([&] { LoadMeshFile(dir + file); }).find("declares"),
              std::string::npos)
        << file;
  }
}

// A FIFO or a symlink to /dev/zero as any input: one line at once, not a
// wait for a writer or an endless read (issue 21). `timeout` turns a hang
// into exit code 124.
TEST(Cli, NonRegularFilesAreRefusedNotWaitedOn) {
  const std::string dir = testing::ScratchDir();
  for (const char* name : {"/in.pcd", "/in.png", "/in.db", "/map.json", "/c.sh3f", "/m.fcm"})
    ASSERT_EQ(::mkfifo((dir + name).c_str(), 0600), 0) << name;
  std::filesystem::create_symlink("/dev/zero", dir + "/zero.pcd");
  struct Case {
    std::string arguments, expected;
  };
  const Case cases[] = {
      {"detect --model " + dir + "/m.fcm --cloud " + dir + "/zero.pcd",
       "zero.pcd: cannot read (a character device"},
      {"detect --model " + dir + "/m.fcm --cloud " FURN_SOURCE_DIR "/data/real/pcl/office1.pcd",
       "m.fcm: cannot read (a FIFO"},
      {"dataset info " + dir + "/in.db", "in.db: cannot read (a FIFO"},
      {"catalog list --catalog " + dir + "/map.json", "map.json: cannot read (a FIFO"},
      {"catalog list --catalog " + dir + "/c.sh3f", "c.sh3f: cannot read (a FIFO"},
  };
  for (const Case& c : cases) {
    const RunResult result =
        testing::RunCommand("timeout 20 " + std::string(FURN_WORKBENCH_BINARY) + " " + c.arguments);
    EXPECT_EQ(result.exit_code, 1) << c.arguments;
    EXPECT_EQ(CountErrorLines(result.output), 1u) << result.output;
    EXPECT_NE(result.output.find(c.expected), std::string::npos) << result.output;
  }
  // The loaders themselves, for the inputs a model is not needed to reach.
  for (const std::string& path : {dir + "/in.pcd", dir + "/zero.pcd"}) {
    try {
      ReadPointCloudFile(path);
      ADD_FAILURE() << path;
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find("inputs must be regular files"), std::string::npos)
          << error.what();
    }
  }
  EXPECT_THROW(ReadDepthImage(dir + "/in.png", std::nullopt), InputError);
  EXPECT_THROW(MappedFile(dir + "/m.fcm"), InputError);
}

// A class map of mesh files alone (issue 19): import, generate (which says
// once that the rooms get no clutter) and list, from the map with no
// --catalog-dir.
TEST(Cli, MeshFolderImportsGeneratesAndSaysWhenThereIsNoClutter) {
  const std::string dir = testing::ScratchDir();
  std::filesystem::create_directories(dir + "/meshes/Tables");
  ExportMesh(MakeBox(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1.2f, 0.7f, 0.74f)),
             dir + "/meshes/Tables/desk.ply");
  const RunResult imported =
      RunWorkbench("catalog import " + dir + "/meshes --out " + dir + "/map.json");
  ASSERT_EQ(imported.exit_code, 0) << imported.output;
  EXPECT_NE(imported.output.find("Tables/desk"), std::string::npos) << imported.output;
  const RunResult generated = RunWorkbench("generate --catalog " + dir +
                                           "/map.json --catalog-dir /nonexistent --rooms 1 "
                                           "--frames 1 --quiet --out " +
                                           dir + "/d.db");
  ASSERT_EQ(generated.exit_code, 0) << generated.output;
  const std::string warning = "offers no clutter";
  const size_t first = generated.output.find(warning);
  EXPECT_NE(first, std::string::npos) << generated.output;
  EXPECT_EQ(generated.output.find(warning, first + 1), std::string::npos) << generated.output;

  // --clutter-catalog adds another catalog's unclassified entries as clutter.
  std::filesystem::create_directories(dir + "/boxes/Clutter");
  ExportMesh(MakeBox(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.5f, 0.4f, 0.35f)),
             dir + "/boxes/Clutter/crate.ply");
  ASSERT_EQ(
      RunWorkbench("catalog import " + dir + "/boxes --class clutter --out " + dir + "/boxes.json")
          .exit_code,
      0);
  const RunResult cluttered = RunWorkbench(
      "generate --catalog " + dir + "/map.json --clutter-catalog " + dir +
      "/boxes.json --catalog-dir /nonexistent --rooms 2 --frames 1 --min-clutter 1 --out " + dir +
      "/c.db");
  ASSERT_EQ(cluttered.exit_code, 0) << cluttered.output;
  EXPECT_EQ(cluttered.output.find(warning), std::string::npos) << cluttered.output;
  EXPECT_NE(cluttered.output.find("clutter: 1 entries of"), std::string::npos) << cluttered.output;
  bool crate = false;
  for (const ModelRecord& model : DatasetDb(dir + "/c.db", DatasetDb::Mode::kReadOnly).ReadModels())
    crate |= model.id == "Clutter/crate";
  EXPECT_TRUE(crate);
  // A catalog with nothing unclassified to add is refused by name.
  const RunResult nothing =
      RunWorkbench("generate --catalog " + dir + "/map.json --clutter-catalog " + dir +
                   "/map.json --catalog-dir /nonexistent --rooms 1 "
                   "--frames 1 --quiet --out " +
                   dir + "/e.db");
  EXPECT_NE(nothing.exit_code, 0);
  EXPECT_NE(nothing.output.find("--clutter-catalog " + dir + "/map.json: no unclassified entry"),
            std::string::npos)
      << nothing.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/e.db"));
}

TEST(Cli, UsageMistakesExitWithTwo) {
  EXPECT_EQ(RunWorkbench("").exit_code, 2);
  EXPECT_EQ(RunWorkbench("frobnicate").exit_code, 2);
  EXPECT_EQ(RunWorkbench("catalog export Test/x").exit_code,
            2);                                     // --out missing
  EXPECT_EQ(RunWorkbench("catalog").exit_code, 2);  // subcommand missing
  // Exit 2 with `expected` in the message.
  const auto expect_usage_error = [](const std::string& arguments, const std::string& expected) {
    const testing::CommandResult result = RunWorkbench(arguments);
    EXPECT_EQ(result.exit_code, 2) << arguments;
    EXPECT_NE(result.output.find(expected), std::string::npos) << result.output;
  };
  // Seeds are unsigned: no wrapping of -1 to 2^64 - 1.
  expect_usage_error("generate --catalog procedural:2 --rooms 1 --seed -1 --out /tmp/x.db",
                     "--seed -1 must be a whole number in 0..2^64-1");
  EXPECT_EQ(RunWorkbench("render --catalog procedural:2 --seed 18446744073709551616 --out /tmp/x")
                .exit_code,
            2);
  // An enum's value by name; a wrong one named with the names it takes.
  expect_usage_error("catalog sheet --catalog procedural --shape-sizes huge --out /tmp/x.png",
                     "--shape-sizes: 'huge' is not one of catalog, real");
  expect_usage_error("detect --voting hough --model /tmp/m.fcm --db /tmp/x.db",
                     "--voting: 'hough' is not one of auto, codebook, learned");
  EXPECT_EQ(RunWorkbench("--help").exit_code, 0);
  const testing::CommandResult version = RunWorkbench("--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_EQ(version.output.rfind("workbench (furnidet) ", 0), 0u) << version.output;
}

// The run's threads: --threads, else FURN_THREADS, else the CPUs the process
// may use (under taskset one); a bad count is one usage line.
TEST(Cli, ThreadsFollowTheFlagTheEnvironmentAndTheAffinity) {
  const std::string wb = FURN_WORKBENCH_BINARY;
  const auto threads_line = [](const testing::CommandResult& run) {
    const size_t at = run.output.find("threads: ");
    return at == std::string::npos ? run.output
                                   : run.output.substr(at, run.output.find('\n', at) - at);
  };
  const testing::CommandResult pinned = testing::RunCommand("taskset -c 0 " + wb + " --version");
  EXPECT_EQ(pinned.exit_code, 0) << pinned.output;
  EXPECT_EQ(threads_line(pinned), "threads: 1 (from CPUs; 1 CPU available to this process)");
  const testing::CommandResult env = testing::RunCommand("FURN_THREADS=3 " + wb + " --version");
  EXPECT_EQ(threads_line(env).rfind("threads: 3 (from FURN_THREADS;", 0), 0u) << env.output;
  const testing::CommandResult flag =
      testing::RunCommand("FURN_THREADS=3 " + wb + " --threads 2 --version");
  EXPECT_EQ(threads_line(flag).rfind("threads: 2 (from --threads;", 0), 0u) << flag.output;
  const testing::CommandResult bad_env =
      testing::RunCommand("FURN_THREADS=two " + wb + " --version");
  EXPECT_EQ(bad_env.exit_code, 2);
  EXPECT_EQ(bad_env.output,
            "workbench: FURN_THREADS='two' must be a whole number in 1..1024 (unset it to use "
            "every CPU available)\n");
  const testing::CommandResult bad_flag = RunWorkbench("--threads 0 --version");
  EXPECT_EQ(bad_flag.exit_code, 2);
  EXPECT_EQ(bad_flag.output, "workbench: --threads '0' must be a whole number in 1..1024\n");
  // The flag reaches the command's own flags untouched.
  const testing::CommandResult command =
      RunWorkbench("--threads=1 catalog list --catalog procedural:2 --quiet");
  EXPECT_EQ(command.exit_code, 0) << command.output;
}

// The rooms cache keeps the rooms itself: with --keep-rooms it is one line
// before anything is trained, and no model file is written.
TEST(Cli, RoomsCacheIsNotCombinedWithKeepRooms) {
  const std::string dir = testing::ScratchDir();
  const testing::CommandResult both =
      RunWorkbench("train --catalog procedural:2 --keep-rooms --rooms-cache " + dir +
                   "/rooms --out " + dir + "/m.fcm");
  EXPECT_EQ(both.exit_code, 1);
  EXPECT_NE(both.output.find("--rooms-cache " + dir + "/rooms keeps the rooms itself"),
            std::string::npos)
      << both.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.fcm"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/rooms"));
}

// The weight average's flags: a decay outside [0, 1) and the last weights
// without an average are one line each, before anything is trained; the
// flags of the three groups (rooms, network, schedule) all reach the options.
TEST(Cli, WeightAverageFlagsAreChecked) {
  const std::string dir = testing::ScratchDir();
  const std::string train = "train --catalog procedural:2 --out " + dir + "/m.fcm ";
  const testing::CommandResult decay = RunWorkbench(train + "--vote-average 1");
  EXPECT_EQ(decay.exit_code, 1);
  EXPECT_EQ(CountErrorLines(decay.output), 1u) << decay.output;
  EXPECT_NE(decay.output.find("vote-net weight average 1.000000 must be in [0, 1)"),
            std::string::npos)
      << decay.output;
  const testing::CommandResult last = RunWorkbench(train + "--vote-keep-last-weights");
  EXPECT_EQ(last.exit_code, 1);
  EXPECT_NE(last.output.find("the last weights are kept only beside a weight average"),
            std::string::npos)
      << last.output;
  const testing::CommandResult ensemble = RunWorkbench(train + "--vote-ensemble 9");
  EXPECT_EQ(ensemble.exit_code, 1);
  EXPECT_NE(ensemble.output.find("vote-net ensemble 9 must be in 1..8 networks"), std::string::npos)
      << ensemble.output;
  const testing::CommandResult groups = RunWorkbench(
      train + "--vote-rooms 0 --vote-width 8 --vote-dense --vote-epochs 2 --vote-average 0.5");
  EXPECT_EQ(groups.exit_code, 1);
  EXPECT_NE(groups.output.find("vote-net rooms 0 must be in 1..100000"), std::string::npos)
      << groups.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.fcm"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.last.fcm"));
}

TEST(CatalogCommands, ListingCountsClassesAndLoadsModels) {
  const Catalog catalog = OpenCatalog("procedural:5");
  ListCatalogOptions options;
  options.load_models = true;
  options.only_class = FurnitureClass::kSideboard;
  const CatalogListing listing = ListCatalog(catalog, options);
  ASSERT_EQ(listing.rows.size(), 4u);
  for (const CatalogListingRow& row : listing.rows) {
    ASSERT_TRUE(row.triangles.has_value());
    EXPECT_GE(*row.triangles, 36u);
    EXPECT_TRUE(row.mesh_size_m.isApprox(row.entry->size_m, 1e-5f));
  }
  EXPECT_NE(FormatCatalogTable(listing).find("4 entries in catalog procedural:5: 4 sideboard"),
            std::string::npos);
}

}  // namespace
}  // namespace furn

namespace furn {
namespace {

TEST(Cli, RenderWritesEveryOutput) {
  const std::string dir = testing::ScratchDir();
  for (const std::string renderer : {"osmesa", "embree"}) {
    const std::string out = dir + "/" + renderer;
    const RunResult result =
        RunWorkbench("render --catalog procedural --entry procedural/chair-1 --quiet --renderer " +
                     renderer + " --out " + out);
    ASSERT_EQ(result.exit_code, 0) << result.output;
    for (const char* name : {"depth_ideal.png",
                             "depth_noisy.png",
                             "ids_ideal.png",
                             "ids_noisy.png",
                             "cloud_ideal.pcd",
                             "cloud_noisy.pcd",
                             "preview.png",
                             "camera.json"}) {
      EXPECT_TRUE(std::filesystem::exists(out + "/" + name)) << name;
    }
    EXPECT_NE(result.output.find("valid pixels: ideal 307200"), std::string::npos) << result.output;
  }
}

TEST(Cli, RenderRejectsBadRequests) {
  const std::string dir = testing::ScratchDir();
  const struct {
    std::string arguments, expected;
  } cases[] = {
      {"--entry procedural/chair-0 --distance -1", "camera distance -1"},
      {"--entry procedural/chair-0 --pitch 95", "camera pitch 95"},
      {"--entry procedural/chair-0 --renderer vulkan", "unknown renderer 'vulkan'"},
      {"--entry procedural/nope", "entry 'procedural/nope' is not in catalog"},
      // A camera inside the top of table-2 (1.62 x 0.66 x 0.78 m, top >= 3 cm thick).
      {"--entry procedural/table-2 --distance 0.1 --height 0.77 --pitch 0",
       "is inside scene object"},
  };
  for (const auto& c : cases) {
    const RunResult result =
        RunWorkbench("render --catalog procedural --quiet --out " + dir + "/x " + c.arguments);
    EXPECT_EQ(result.exit_code, 1) << c.arguments;
    EXPECT_NE(result.output.find(c.expected), std::string::npos) << result.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/x/preview.png"));
}

// Issue 72: a `train` killed (SIGKILL) in the vote network's third epoch and
// run again resumes after its last whole epoch from `<out>.checkpoint` and
// writes the model an uninterrupted training writes, byte for byte (one
// torch thread); the checkpoint is gone once the model is written.
TEST(Cli, ATrainingKilledMidEpochResumesToTheSameModelBytes) {
  const std::string dir = testing::ScratchDir();
  const std::string train =
      std::string(FURN_WORKBENCH_BINARY) +
      " train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 3 --vote-rooms 12 "
      "--vote-frames 4 --vote-epochs 4 --vote-threads 1 --rooms-cache " +
      dir + "/rooms --out ";
  const RunResult whole = testing::RunCommand(train + dir + "/whole.fcm 2>&1");
  ASSERT_EQ(whole.exit_code, 0) << whole.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/whole.fcm.checkpoint"));

  // The same training in the background, killed once its second epoch is done.
  const std::string log = dir + "/killed.log";
  const std::string pid = testing::StartInBackground(train + dir + "/resumed.fcm", log);
  ASSERT_TRUE(testing::WaitUntil(
      [&] { return ReadFileBytes(log).find("vote net: epoch 2/4") != std::string::npos; }, 600))
      << ReadFileBytes(log);
  testing::KillHard(pid);
  const std::string killed_at = ReadFileBytes(log);
  EXPECT_EQ(killed_at.find("vote net: epoch 4/4"), std::string::npos) << "killed too late";
  EXPECT_FALSE(std::filesystem::exists(dir + "/resumed.fcm"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/resumed.fcm.checkpoint"));

  const RunResult resumed = testing::RunCommand(train + dir + "/resumed.fcm 2>&1");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_NE(resumed.output.find("vote net: resuming after epoch"), std::string::npos)
      << resumed.output;
  EXPECT_EQ(resumed.output.find("vote net: epoch 1/4"), std::string::npos) << resumed.output;
  EXPECT_TRUE(ReadFileBytes(dir + "/resumed.fcm") == ReadFileBytes(dir + "/whole.fcm"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/resumed.fcm.checkpoint"));
}

// Issue 31 without a cluster: `train --shards 3 --emit-only` writes the array
// job's scripts; each task generates a third of the vote network's training
// rooms, and the final script (merge, then train) writes the same model file,
// byte for byte, as one process. A missing task's rooms are refused before
// anything trains.
TEST(Cli, TrainWithItsTrainingRoomsAsTasksWritesTheOneProcessModel) {
  const std::string dir = testing::ScratchDir();
  const std::string train =
      "train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 6 --vote-rooms 8 "
      "--vote-frames 2 --vote-epochs 1 --vote-threads 1 --quiet --out ";
  ASSERT_EQ(RunWorkbench(train + dir + "/one.fcm").exit_code, 0);
  const std::string job = dir + "/job";
  const RunResult emit =
      RunWorkbench(train + dir + "/array.fcm --shards 3 --emit-only --job-dir " + job);
  ASSERT_EQ(emit.exit_code, 0) << emit.output;
  for (int k = 0; k < 3; ++k) {
    const RunResult task = testing::RunCommand("SLURM_ARRAY_TASK_ID=" + std::to_string(k) +
                                               " bash " + job + "/task.sbatch");
    ASSERT_EQ(task.exit_code, 0) << task.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/array.fcm"));  // the tasks train nothing
  const RunResult final_step = testing::RunCommand("bash " + job + "/final.sbatch");
  ASSERT_EQ(final_step.exit_code, 0) << final_step.output;
  EXPECT_EQ(ReadFileBytes(dir + "/array.fcm"), ReadFileBytes(dir + "/one.fcm"));

  const RunResult missing = RunWorkbench(train + dir + "/missing.fcm --vote-rooms-from " + job +
                                         "/rooms-0.db " + job + "/rooms-2.db");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.output.find("the 2 training-room shards hold 5 of the 8 rooms"),
            std::string::npos)
      << missing.output;
  const RunResult codebook = RunWorkbench(
      train + dir + "/c.fcm --no-vote-net --shards 2 --emit-only --job-dir " + dir + "/job2");
  EXPECT_EQ(codebook.exit_code, 1);
  EXPECT_NE(codebook.output.find("with --no-vote-net there are none"), std::string::npos)
      << codebook.output;
}

// Issue 70 without a cluster: `train --vote-workers 2 --emit-only` writes a
// rooms task and a final job of two tasks (srun); run by a stand-in srun
// that starts the command twice with SLURM_PROCID 0 and 1, as Slurm would,
// they train the same bytes as two local processes.
TEST(Cli, TrainAsTwoSlurmTasksWritesTheLocalWorkersModel) {
  const std::string dir = testing::ScratchDir();
  const std::string train =
      "train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 6 --vote-rooms 6 "
      "--vote-frames 2 --vote-epochs 1 --vote-threads 1 --quiet --out ";
  ASSERT_EQ(RunWorkbench(train + dir + "/local.fcm --vote-workers 2").exit_code, 0);
  const std::string job = dir + "/job";
  const RunResult emit = RunWorkbench(
      train + dir + "/slurm.fcm --vote-workers 2 --nodes 2 --emit-only --job-dir " + job);
  ASSERT_EQ(emit.exit_code, 0) << emit.output;
  const std::string script = ReadFileBytes(job + "/final.sbatch");
  EXPECT_NE(script.find("#SBATCH --ntasks=2\n#SBATCH --nodes=2\n"), std::string::npos) << script;
  EXPECT_NE(script.find("srun --kill-on-bad-exit=1 "), std::string::npos) << script;
  EXPECT_EQ(script.find("--nodes 2"), std::string::npos) << "the tasks get no --nodes";
  const std::string bin = dir + "/bin";
  std::filesystem::create_directories(bin);
  WriteFileAtomically(bin + "/srun",
                      "#!/bin/bash\nshift\n"
                      "SLURM_PROCID=0 SLURM_NTASKS=2 SLURM_JOB_ID=7 \"$@\" & zero=$!\n"
                      "SLURM_PROCID=1 SLURM_NTASKS=2 SLURM_JOB_ID=7 \"$@\"; one=$?\n"
                      "wait $zero; [ $? -eq 0 ] && [ $one -eq 0 ]\n");
  std::filesystem::permissions(bin + "/srun", std::filesystem::perms::owner_all);
  const RunResult task = testing::RunCommand("SLURM_ARRAY_TASK_ID=0 bash " + job + "/task.sbatch");
  ASSERT_EQ(task.exit_code, 0) << task.output;
  const RunResult final_step =
      testing::RunCommand("PATH=" + bin + ":$PATH bash " + job + "/final.sbatch");
  ASSERT_EQ(final_step.exit_code, 0) << final_step.output;
  EXPECT_TRUE(ReadFileBytes(dir + "/slurm.fcm") == ReadFileBytes(dir + "/local.fcm"));
  EXPECT_FALSE(std::filesystem::exists(job + "/group/store-7")) << "the store is left behind";
  const RunResult other_size = testing::RunCommand(
      "SLURM_PROCID=0 SLURM_NTASKS=3 " + std::string(FURN_WORKBENCH_BINARY) + " " + train + dir +
      "/x.fcm --vote-workers 2 --vote-slurm-group " + job + "/group 2>&1");
  EXPECT_EQ(other_size.exit_code, 1);
  EXPECT_NE(other_size.output.find("this Slurm job has 3 tasks, --vote-workers 2"),
            std::string::npos)
      << other_size.output;
}

// `train --vote-member 1` trains another network of the same rooms (10:
// the tenth validates);
// `model ensemble` combines the members' vote networks into member 1's model
// (the operating point chosen again on the training rooms when given), and
// `model info` says so. A model without a vote network is refused by name,
// nothing written; one member alone is a usage error.
TEST(Cli, ModelEnsembleCombinesMembersOfOneTraining) {
  const std::string dir = testing::ScratchDir();
  const std::string train =
      "train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 3 --vote-rooms 10 "
      "--vote-frames 2 --vote-epochs 1 --vote-threads 1 --quiet --out ";
  ASSERT_EQ(RunWorkbench(train + dir + "/m0.fcm --keep-rooms").exit_code, 0);
  ASSERT_EQ(RunWorkbench(train + dir + "/m1.fcm --vote-member 1").exit_code, 0);
  EXPECT_NE(ReadFileBytes(dir + "/m0.fcm"), ReadFileBytes(dir + "/m1.fcm"));
  const RunResult combined =
      RunWorkbench("model ensemble " + dir + "/m0.fcm " + dir + "/m1.fcm --out " + dir +
                   "/pair.fcm --training-rooms " + dir + "/m0.fcm.rooms.db");
  ASSERT_EQ(combined.exit_code, 0) << combined.output;
  EXPECT_NE(combined.output.find("an ensemble of 2 vote networks; operating point chosen on"),
            std::string::npos)
      << combined.output;
  const RunResult info = RunWorkbench("model info " + dir + "/pair.fcm");
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("vote net:    an ensemble of 2 U-Nets"), std::string::npos)
      << info.output;
  EXPECT_NE(info.output.find("vote net input: single frames"), std::string::npos) << info.output;
  const RunResult kept = RunWorkbench("model ensemble " + dir + "/m0.fcm " + dir +
                                      "/m1.fcm --out " + dir + "/kept.fcm");
  ASSERT_EQ(kept.exit_code, 0) << kept.output;
  EXPECT_NE(kept.output.find("operating point member 1's"), std::string::npos) << kept.output;

  ASSERT_EQ(RunWorkbench(train + dir + "/cb.fcm --no-vote-net").exit_code, 0);
  const RunResult codebook = RunWorkbench("model ensemble " + dir + "/m0.fcm " + dir +
                                          "/cb.fcm --out " + dir + "/bad.fcm");
  EXPECT_EQ(codebook.exit_code, 1);
  EXPECT_EQ(CountErrorLines(codebook.output), 1u) << codebook.output;
  EXPECT_NE(codebook.output.find("cb.fcm: has no vote network to combine"), std::string::npos)
      << codebook.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.fcm"));
  // A member trained on other input (here: fused frames) is no member.
  ASSERT_EQ(
      RunWorkbench(train + dir + "/fused.fcm --vote-member 1 --vote-fused-share 0.5").exit_code, 0);
  const RunResult fused = RunWorkbench("model ensemble " + dir + "/m0.fcm " + dir +
                                       "/fused.fcm --out " + dir + "/bad.fcm");
  EXPECT_EQ(fused.exit_code, 1);
  EXPECT_NE(fused.output.find("fused.fcm: its vote network was trained on fused frames in 50 % "
                              "of its training, exact poses, "),
            std::string::npos)
      << fused.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.fcm"));
  // Detection says when a network meets the other kind of input.
  const RunResult single = RunWorkbench("detect --model " + dir + "/fused.fcm --db " + dir +
                                        "/m0.fcm.rooms.db --frame 1");
  EXPECT_NE(single.output.find("note: " + dir +
                               "/fused.fcm: its vote network was trained for "
                               "fused scans"),
            std::string::npos)
      << single.output;
  const RunResult fused_input = RunWorkbench("detect --model " + dir + "/m0.fcm --db " + dir +
                                             "/m0.fcm.rooms.db --frame 1 --fuse");
  EXPECT_NE(fused_input.output.find("trained on single frames; for fused scans"), std::string::npos)
      << fused_input.output;
  const RunResult nested = RunWorkbench("model ensemble " + dir + "/pair.fcm " + dir +
                                        "/m1.fcm --out " + dir + "/bad.fcm");
  EXPECT_EQ(nested.exit_code, 1);
  EXPECT_NE(nested.output.find("pair.fcm: is an ensemble already"), std::string::npos)
      << nested.output;
  EXPECT_EQ(RunWorkbench("model ensemble " + dir + "/m0.fcm --out " + dir + "/bad.fcm").exit_code,
            2);
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.fcm"));
}

// `adapt` (issue 69): a learned model's batch normalisation statistics
// re-estimated on scans without labels: a dataset's frames, scan files (the
// floor found) or both; or self-training on them; the same seed gives the
// same bytes, the adapted model detects. A codebook model, no scans, too few usable scans and bad
// values are one line each, exit 1, nothing written.
TEST(Cli, AdaptReestimatesTheStatisticsOnUnlabelledScans) {
  const std::string dir = testing::ScratchDir();
  const std::string train =
      "train --catalog procedural:4 --vocab kmeans --words 20 --azimuths 6 --vote-rooms 10 "
      "--vote-frames 2 --vote-epochs 1 --vote-threads 1 --quiet --out ";
  ASSERT_EQ(RunWorkbench(train + dir + "/m.fcm --keep-rooms").exit_code, 0);
  ASSERT_EQ(RunWorkbench("generate --catalog procedural:4 --rooms 3 --frames 2 --seed 11 --quiet "
                         "--out " +
                         dir + "/scans.db")
                .exit_code,
            0);
  const std::string adapt = "adapt --model " + dir + "/m.fcm --batch 2 ";
  const RunResult db = RunWorkbench(adapt + "--db " + dir + "/scans.db --out " + dir + "/a.fcm");
  ASSERT_EQ(db.exit_code, 0) << db.output;
  EXPECT_NE(db.output.find("batch normalisations re-estimated on 6 of 6 scans"), std::string::npos)
      << db.output;
  EXPECT_NE(db.output.find("operating point: the model's"), std::string::npos) << db.output;
  EXPECT_NE(ReadFileBytes(dir + "/a.fcm"), ReadFileBytes(dir + "/m.fcm"));
  ASSERT_EQ(RunWorkbench(adapt + "--db " + dir + "/scans.db --out " + dir + "/b.fcm").exit_code, 0);
  EXPECT_EQ(ReadFileBytes(dir + "/a.fcm"), ReadFileBytes(dir + "/b.fcm"));
  const RunResult other =
      RunWorkbench(adapt + "--db " + dir + "/scans.db --seed 2 --out " + dir + "/c.fcm --quiet");
  ASSERT_EQ(other.exit_code, 0) << other.output;
  EXPECT_TRUE(other.output.empty()) << other.output;
  const RunResult files =
      RunWorkbench(adapt + FURN_SOURCE_DIR "/data/real/pcl/capture000?.pcd --db " + dir +
                   "/scans.db --out " + dir + "/d.fcm");
  ASSERT_EQ(files.exit_code, 0) << files.output;
  EXPECT_NE(files.output.find("scans (blend 1.00"), std::string::npos) << files.output;
  const RunResult detect =
      RunWorkbench("detect --model " + dir +
                   "/a.fcm --cloud " FURN_SOURCE_DIR "/data/real/pcl/office1.pcd --quiet");
  EXPECT_EQ(detect.exit_code, 0) << detect.output;

  // Self-training: pseudo-labels on the scans, fine-tuned beside the model's
  // own training rooms, the operating point chosen again on their
  // validation room; the same seed gives the same bytes.
  const std::string self = adapt + "--db " + dir + "/scans.db --method self-training --rooms " +
                           dir + "/m.fcm.rooms.db ";
  const RunResult tuned = RunWorkbench(self + "--epochs 1 --out " + dir + "/s1.fcm");
  ASSERT_EQ(tuned.exit_code, 0) << tuned.output;
  EXPECT_NE(tuned.output.find("fine-tuned on 6 of 6 scans with"), std::string::npos)
      << tuned.output;
  EXPECT_NE(tuned.output.find("(after self-training) (no label of the scans was read)"),
            std::string::npos)
      << tuned.output;
  ASSERT_EQ(RunWorkbench(self + "--epochs 1 --out " + dir + "/s2.fcm --quiet").exit_code, 0);
  EXPECT_EQ(ReadFileBytes(dir + "/s1.fcm"), ReadFileBytes(dir + "/s2.fcm"));
  EXPECT_NE(ReadFileBytes(dir + "/s1.fcm"), ReadFileBytes(dir + "/m.fcm"));
  EXPECT_EQ(RunWorkbench("detect --model " + dir +
                         "/s1.fcm --cloud " FURN_SOURCE_DIR "/data/real/pcl/office1.pcd --quiet")
                .exit_code,
            0);

  ASSERT_EQ(RunWorkbench(train + dir + "/cb.fcm --no-vote-net").exit_code, 0);
  const std::string scans = adapt + "--db " + dir + "/scans.db ";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {scans + "--method self-training", "--method self-training needs --rooms"},
      {scans + "--rooms " + dir + "/m.fcm.rooms.db", "--rooms applies to --method self-training"},
      {scans + "--method sideways", "'sideways'"},
      {self + "--epochs 0", "--epochs must be in 1..100 (got 0)"},
      {self + "--pseudo-share 0", "--pseudo-share must be in (0, 4]"},
      {scans + "--method self-training --rooms " + dir + "/missing.db", "missing.db"},
      {"adapt --model " + dir + "/cb.fcm --db " + dir + "/scans.db",
       "has no vote network to adapt"},
      {adapt, "adapt needs scans: --db, scan files or --bag"},
      {adapt + "--db " + dir + "/scans.db --blend 2", "--blend must be in [0, 1] (got 2"},
      {adapt + "--db " + dir + "/scans.db --max-frames 1", "fewer than one batch of 2"},
      {adapt + "--db " + dir + "/missing.db", "missing.db"},
      {adapt + "--db " + dir + "/scans.db --split sideways", "--split 'sideways' must be"},
  };
  for (const auto& [arguments, message] : bad) {
    const RunResult result = RunWorkbench(arguments + " --quiet --out " + dir + "/bad.fcm");
    EXPECT_EQ(result.exit_code, 1) << arguments;
    EXPECT_EQ(CountErrorLines(result.output), 1u) << result.output;
    EXPECT_NE(result.output.find(message), std::string::npos) << result.output;
    EXPECT_FALSE(std::filesystem::exists(dir + "/bad.fcm")) << arguments;
  }
}

}  // namespace
}  // namespace furn
