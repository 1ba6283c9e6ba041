// Issue 68, the fourth hostile-input round: every kind of sample of
// ../shared/crashers/turn5/ rebuilt here from a small model and dataset,
// through the workbench binary as a user runs it. Each ends in one line
// naming the file (exit 1..123) within 10 s, nothing runs, no user file is
// lost. The shared samples themselves run too when that folder exists.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "core/model/trained_model.h"
#include "core/util/file_util.h"
#include "db/sqlite.h"
#include "renderers/depth_frame.h"
#include "tests/test_util.h"
#include "tests/workbench/workbench_commands.h"
#include "workbench/formats/depth_png.h"

namespace furn {
namespace {

namespace fs = std::filesystem;

class HostileTurn5 : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::ScratchDir());
    model_ = new std::string(*dir_ + "/model.fcm");
    db_ = new std::string(*dir_ + "/tiny.db");
    ASSERT_EQ(Run(std::string(testing::kTrainSmallCodebook) + *model_).exit_code, 0);
    ASSERT_EQ(
        Run("generate --catalog procedural:4 --rooms 1 --frames 1 --seed 1 --quiet --out " + *db_)
            .exit_code,
        0);
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete model_;
    delete db_;
  }

  static testing::CommandResult Run(const std::string& arguments) {
    return testing::RunCommand("cd '" + *dir_ + "' && " + FURN_WORKBENCH_BINARY + " " + arguments);
  }

  // One line naming `name`, exit 1..123, within 10 s.
  static std::string ExpectOneLine(const std::string& arguments, const std::string& name) {
    const auto start = std::chrono::steady_clock::now();
    const testing::CommandResult result = Run(arguments);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_GE(result.exit_code, 1) << arguments << ": " << result.output;
    EXPECT_LE(result.exit_code, 123) << arguments << ": " << result.output;
    EXPECT_EQ(result.output.find('\n'), result.output.size() - 1)
        << arguments << ": " << result.output;
    EXPECT_NE(result.output.find(name), std::string::npos) << arguments << ": " << result.output;
    EXPECT_EQ(result.output.find("json.exception"), std::string::npos) << result.output;
    EXPECT_LT(seconds, 10) << arguments;
    return result.output;
  }

  // The small model with `mutate` applied, saved (with a fresh checksum) as `name`.
  template <typename Mutate>
  static std::string MutatedModel(const std::string& name, Mutate mutate) {
    TrainedModel model = LoadTrainedModelUnchecked(*model_);
    mutate(&model);
    const std::string path = *dir_ + "/" + name + ".fcm";
    SaveTrainedModel(model, path);
    return path;
  }

  static std::string* dir_;
  static std::string* model_;
  static std::string* db_;
};

std::string* HostileTurn5::dir_ = nullptr;
std::string* HostileTurn5::model_ = nullptr;
std::string* HostileTurn5::db_ = nullptr;

// model_shape_*: bounds and points the fitter sizes its grids by.
TEST_F(HostileTurn5, ModelShapesAreCheckedOnLoad) {
  const auto detect = [](const std::string& model) {
    return "detect --model " + model + " --db tiny.db --frame 0 --quiet";
  };
  const std::string high =
      MutatedModel("shape_high", [](TrainedModel* m) { m->model_shapes.at(0).high.z() = 1e6f; });
  EXPECT_NE(ExpectOneLine(detect(high), high).find("bounds are not its points' bounding box"),
            std::string::npos);
  const std::string nan = MutatedModel(
      "shape_nan", [](TrainedModel* m) { m->model_shapes.at(0).points.at(0).x() = std::nanf(""); });
  EXPECT_NE(ExpectOneLine(detect(nan), nan).find("point 0 is not finite"), std::string::npos);
  const std::string outside = MutatedModel(
      "shape_outside", [](TrainedModel* m) { m->model_shapes.at(0).points.back().z() += 10000; });
  ExpectOneLine(detect(outside), outside);
}

// model_name_bad_utf8, model_options_nan_voxel, model_chosen_on_ansi.
TEST_F(HostileTurn5, ModelTextAndOptionsNameTheFile) {
  const std::string bad_name =
      MutatedModel("bad_name", [](TrainedModel* m) { m->model_names.at(0) = "chair\xFF\xFE"; });
  EXPECT_NE(ExpectOneLine("model info " + bad_name, bad_name).find("is not valid UTF-8"),
            std::string::npos);
  const std::string voxel = MutatedModel(
      "nan_voxel", [](TrainedModel* m) { m->options.preprocess.voxel_size_m = std::nan(""); });
  EXPECT_NE(ExpectOneLine("model info " + voxel, voxel).find("trainer options"), std::string::npos);
  const std::string ansi = MutatedModel("ansi", [](TrainedModel* m) {
    m->operating_point.chosen_on = "frames\x1B[2J\nforged: line";
    for (ClassOperatingPoint& c : m->operating_point.classes) c.min_score = 0.5;
  });
  const testing::CommandResult info = Run("model info " + ansi);
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_EQ(info.output.find('\x1B'), std::string::npos) << info.output;
  EXPECT_EQ(info.output.find("\nforged"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("frames\\x1B[2J\\nforged: line"), std::string::npos) << info.output;
}

// options_fit_iterations_1e8 and duplicate keys: an options file is bounded.
TEST_F(HostileTurn5, OptionsFilesAreBounded) {
  const std::string iterations = *dir_ + "/iterations.json";
  testing::WriteText(iterations, R"({"detector": {"fit": {"iterations": 100000000}}})");
  EXPECT_NE(ExpectOneLine(
                "detect --model model.fcm --db tiny.db --frame 0 --quiet --options " + iterations,
                "fit iterations 100000000 must be in 1..20000")
                .find("iterations.json"),
            std::string::npos);
  const std::string twice = *dir_ + "/twice.json";
  testing::WriteText(twice, R"({"detector": {"fit": {"iterations": 10, "iterations": 20}}})");
  ExpectOneLine("detect --model model.fcm --db tiny.db --frame 0 --quiet --options " + twice,
                "key \"iterations\" appears twice");
  ExpectOneLine("detect --model model.fcm --frobnicate", "workbench detect: error:");
}

// fuse_tum_3000: every fused scan is held at once, so their count is capped
// before any is read.
TEST_F(HostileTurn5, FusionIsBoundedBeforeReading) {
  DepthFrame frame;
  frame.Resize(64, 48);
  for (float& z : frame.depth) z = 2.0f;
  WriteFileAtomically(*dir_ + "/depth.png", [&] {
    const std::vector<uint8_t> png = EncodeDepthPng(frame, 1000);
    return std::string(png.begin(), png.end());
  }());
  std::string list;
  for (int k = 0; k < 3000; ++k) list += std::to_string(k) + ".0 depth.png\n";
  testing::WriteText(*dir_ + "/tum.txt", list);
  ExpectOneLine(
      "detect --model model.fcm --fuse --floor-aligned --world-from-camera "
      "'t=0,0,1.5 q=-0.5,0.5,-0.5,0.5' --intrinsics 525,525,319.5,239.5 tum.txt --quiet",
      "more than --fuse-max-scans 64");
}

// history_kind_newline_runs_shell, report_results_not_object,
// report_options_not_json, report_stored_fusion_noise: a dataset's run rows
// are data, for the plots too.
TEST_F(HostileTurn5, RunRowsNeverBecomeAProgram) {
  const std::string db = *dir_ + "/runs.db";
  fs::copy_file(*db_, db, fs::copy_options::overwrite_existing);
  ASSERT_EQ(Run("evaluate --model model.fcm --db runs.db --split all --quiet").exit_code, 0);
  const std::string kind =
      "evaluate'\n!touch pwned_by_history\n$(touch pwned_dollar) `touch pwned_tick` </script> "
      "\x1B[2J \u2028 \xF0\x9F\x98\x80 # \\";
  {
    Database runs(db, Database::Mode::kReadWriteExisting);
    Statement update(&runs, "UPDATE runs SET kind = ?, label = ?");
    update.Bind(1, kind).Bind(2, kind).Run();
  }
  const testing::CommandResult history = Run("history --db runs.db --out hist");
  EXPECT_EQ(history.exit_code, 0) << history.output;
  for (const char* pwned : {"pwned_by_history", "pwned_dollar", "pwned_tick"})
    EXPECT_FALSE(fs::exists(*dir_ + "/" + pwned)) << pwned;
  const std::string html = ReadFileBytes(*dir_ + "/hist/history.html");
  EXPECT_EQ(html.find("</script> "), std::string::npos);
  EXPECT_NE(html.find("&lt;/script&gt;"), std::string::npos);
  for (int p = 0; p < 6; ++p)
    EXPECT_GT(fs::file_size(*dir_ + "/hist/history_" + std::to_string(p) + ".png"), 1000u) << p;
  {
    Database runs(db, Database::Mode::kReadWriteExisting);
    runs.Execute("UPDATE runs SET results_json = '[1, 2]'");
  }
  ExpectOneLine("report --db runs.db --out rep", "runs.db: run");
  {
    Database runs(db, Database::Mode::kReadWriteExisting);
    runs.Execute(
        "UPDATE runs SET results_json = '{}', options_json = 'not json', "
        "model_path = 'gone.fcm'");
  }
  ExpectOneLine("report --db runs.db --out rep", "runs.db: run");
}

// The shared samples, when this checkout sits beside them: the ones that
// need no trained default model (those run in the closing note's sweep).
TEST_F(HostileTurn5, SharedSamplesEndInOneLine) {
  const std::string shared = FURN_SOURCE_DIR "/../shared/crashers/turn5";
  if (!fs::is_directory(shared)) GTEST_SKIP() << shared << " is not here";
  const std::string history = *dir_ + "/shared_history.db";
  fs::copy_file(shared + "/history_kind_newline_runs_shell.db",
                history,
                fs::copy_options::overwrite_existing);
  EXPECT_EQ(Run("history --db shared_history.db --out shared_hist").exit_code, 0);
  EXPECT_FALSE(fs::exists(*dir_ + "/pwned_by_history"));
  for (const char* sample :
       {"report_results_not_object", "report_options_not_json", "report_stored_fusion_noise"}) {
    fs::copy_file(shared + "/" + sample + ".db",
                  *dir_ + "/" + sample + ".db",
                  fs::copy_options::overwrite_existing);
    ExpectOneLine(std::string("report --db ") + sample + ".db --out rep_" + sample, sample);
  }
  for (const char* bag : {"ros2_generated_200_frames",
                          "ros2_generated_image_11000",
                          "ros2_text_nul_900MB",
                          "ros2_compressed_messages"}) {
    ExpectOneLine("detect --model model.fcm --bag " + shared + "/" + bag +
                      " --topic /camera/depth/image_raw --quiet",
                  bag);
  }
  const testing::CommandResult catalog =
      Run("catalog list --catalog " + shared + "/catalog_surrogate_pair.sh3f --all");
  EXPECT_EQ(catalog.exit_code, 0) << catalog.output;
  EXPECT_NE(catalog.output.find("\U0001F600"), std::string::npos) << catalog.output;
}

}  // namespace
}  // namespace furn
