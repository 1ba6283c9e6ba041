// The rooms cache (issue 37): a training of the same rooms reuses them and
// trains the same network byte for byte; a file another generator made is
// made again; one training of the same rooms at a time. Fused training
// frames are rasterised with their room-mates.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "core/util/error.h"
#include "core/util/progress.h"
#include "db/sqlite.h"
#include "tests/test_util.h"
#include "workbench/formats/scan_file.h"
#include "workbench/pipelines/rooms_cache.h"
#include "workbench/pipelines/train_vote_net.h"

namespace furn {
namespace {

VoteNetTrainingOptions TinyTraining() {
  VoteNetTrainingOptions options;
  options.rooms = 3;
  options.frames_per_room = 2;
  options.epochs = 1;
  options.net.width = 4;
  options.quiet = true;
  return options;
}

GenerateOptions TwoRooms() {
  GenerateOptions generate;
  generate.catalog_spec = "procedural:2";
  generate.rooms = 2;
  generate.room.frames_per_room = 1;
  return generate;
}

size_t FilesIn(const std::string& dir, const std::string& extension) {
  size_t count = 0;
  for (const auto& file : std::filesystem::directory_iterator(dir))
    count += file.path().extension() == extension;
  return count;
}

// Where the training's time goes (issue 70): every stage is timed, the
// steps counted, and the step's parts lie within the training's time.
TEST(RoomsCache, TheTrainingsStagesAreTimed) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  const VoteNetTrainingOptions options = TinyTraining();
  VoteNetTrainingSummary summary;
  TrainVoteNet(catalog, {}, options, dir + "/rooms.db", &summary);
  const VoteNetStageTimes& t = summary.stages;
  EXPECT_GT(t.generate_s, 0);
  EXPECT_GT(t.read_s, 0);
  EXPECT_GT(t.raster_s, 0);
  EXPECT_LE(t.read_s + t.raster_s, summary.raster_s + 1e-6);
  const int64_t steps_per_epoch = (summary.frames + options.batch_size - 1) / options.batch_size;
  EXPECT_EQ(t.steps, steps_per_epoch * options.epochs);
  EXPECT_GT(t.batch_s, 0);
  EXPECT_GT(t.tensors_s, 0);
  EXPECT_GT(t.forward_s, 0);
  EXPECT_GT(t.backward_s, 0);
  EXPECT_GT(t.update_s, 0);
  EXPECT_LE(t.batch_s + t.tensors_s + t.forward_s + t.backward_s + t.update_s + t.average_s +
                t.validation_s,
            summary.train_s + 1e-6);
  EXPECT_NE(t.Text().find("forward"), std::string::npos) << t.Text();
}

TEST(RoomsCache, SameRoomsAreReusedAndTrainTheSameNetwork) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  VoteNetTrainingOptions options = TinyTraining();
  VoteNetTrainingSummary plain_summary;
  const std::string plain = TrainVoteNet(catalog, {}, options, dir + "/plain.db", &plain_summary);
  EXPECT_EQ(plain_summary.rooms_reused, 0);

  options.rooms_cache = dir + "/cache";
  VoteNetTrainingSummary made, reused, wider;
  EXPECT_EQ(TrainVoteNet(catalog, {}, options, dir + "/made.db", &made), plain);
  EXPECT_EQ(made.rooms_reused, 0);
  EXPECT_EQ(TrainVoteNet(catalog, {}, options, dir + "/reused.db", &reused), plain);
  EXPECT_EQ(reused.rooms_reused, 3);
  EXPECT_EQ(reused.frames, plain_summary.frames);
  // The model's own rooms file is not written: the cache holds them.
  EXPECT_FALSE(std::filesystem::exists(dir + "/made.db"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/reused.db"));
  EXPECT_EQ(FilesIn(dir + "/cache", ".db"), 1u);

  // Another network on the same rooms reuses them; other rooms (a model
  // held out) are another file.
  options.net.width = 6;
  EXPECT_NE(TrainVoteNet(catalog, {}, options, dir + "/wider.db", &wider), plain);
  EXPECT_EQ(wider.rooms_reused, 3);
  VoteNetTrainingSummary held_out;
  TrainVoteNet(catalog, {catalog.Classified().front()->id}, options, dir + "/held.db", &held_out);
  EXPECT_EQ(held_out.rooms_reused, 0);
  EXPECT_EQ(FilesIn(dir + "/cache", ".db"), 2u);
  EXPECT_EQ(FilesIn(dir + "/cache", ".lock"), 2u);

  // The cache keeps the rooms; keeping them beside the model too, or merging
  // shards into it, is refused in one line naming both.
  options.keep_rooms = true;
  const std::string both = testing::ErrorOf([&] { options.Check(); });
  EXPECT_NE(both.find("--keep-rooms"), std::string::npos) << both;
  EXPECT_NE(both.find("--rooms-cache"), std::string::npos) << both;
  options.keep_rooms = false;
  options.room_shards = {dir + "/shard.db"};
  EXPECT_NE(testing::ErrorOf([&] { options.Check(); }).find("--rooms-cache"), std::string::npos);
  options.room_shards.clear();
  std::ofstream(dir + "/file") << "x";
  options.rooms_cache = dir + "/file";
  EXPECT_NE(testing::ErrorOf([&] { options.Check(); }).find("must be a directory"),
            std::string::npos);
}

TEST(RoomsCache, KeyFollowsTheRoomsAndTheCatalog) {
  const Catalog catalog = OpenCatalog("procedural:2");
  const GenerateOptions generate = TwoRooms();
  const std::string key = RoomsCacheKey(catalog, generate);
  EXPECT_EQ(key.size(), 16u);
  EXPECT_EQ(RoomsCacheKey(OpenCatalog("procedural:2"), generate), key);
  GenerateOptions other = generate;
  other.seed = 2;
  EXPECT_NE(RoomsCacheKey(catalog, other), key);
  other = generate;
  other.excluded_models = {catalog.Classified().front()->id};
  EXPECT_NE(RoomsCacheKey(catalog, other), key);
  EXPECT_NE(RoomsCacheKey(OpenCatalog("procedural:3"), generate), key);
  other = generate;
  other.shard_index = 1;  // shards make one run's rooms
  other.shard_count = 2;
  EXPECT_EQ(RoomsCacheKey(catalog, other), key);
}

TEST(RoomsCache, AFileOfAnotherGeneratorIsMadeAgain) {
  Progress::SetQuiet(true);
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  const GenerateOptions generate = TwoRooms();
  std::string path;
  {
    const CachedRooms rooms(dir, catalog, generate, true);
    path = rooms.path();
    EXPECT_EQ(rooms.rooms_present(), 0);
    GenerateDataset(catalog, generate, path);
  }
  {
    const CachedRooms rooms(dir, catalog, generate, true);
    EXPECT_EQ(rooms.path(), path);
    EXPECT_EQ(rooms.rooms_present(), 2);
  }
  // As if another renderer had drawn the first room: its frames differ.
  Database(path).Execute("UPDATE frames SET content_hash = 'other' WHERE room_id = 0");
  {
    const CachedRooms rooms(dir, catalog, generate, true);
    EXPECT_EQ(rooms.rooms_present(), 0);
    EXPECT_FALSE(std::filesystem::exists(path));
    EXPECT_FALSE(std::filesystem::exists(path + ".check.db"));
  }
  // A damaged file: one line naming it and what to do.
  std::ofstream(path) << "not a database";
  const std::string damaged = testing::ErrorOf([&] { CachedRooms(dir, catalog, generate, true); });
  EXPECT_NE(damaged.find(path), std::string::npos) << damaged;
  EXPECT_NE(damaged.find("delete it to make the rooms again"), std::string::npos) << damaged;
  EXPECT_EQ(damaged.find('\n'), std::string::npos) << damaged;
  // A cache directory that is a file: one line naming it.
  std::ofstream(dir + "/file") << "x";
  const std::string error =
      testing::ErrorOf([&] { CachedRooms(dir + "/file", catalog, generate, true); });
  EXPECT_NE(error.find(dir + "/file"), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
}

TEST(RoomsCache, OneUserOfTheSameRoomsAtATime) {
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog("procedural:2");
  const GenerateOptions generate = TwoRooms();
  std::atomic<bool> second_in{false};
  std::thread second;
  {
    const CachedRooms first(dir, catalog, generate, true);
    second = std::thread([&] {
      const CachedRooms waiting(dir, catalog, generate, true);
      second_in = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_FALSE(second_in.load());
  }
  second.join();
  EXPECT_TRUE(second_in.load());
}

// Two rooms of four frames each, for fused training frames.
void WriteFourFrameRooms(const std::string& db_path) {
  Progress::SetQuiet(true);
  GenerateOptions generate = TwoRooms();
  generate.room.frames_per_room = 4;
  GenerateDataset(OpenCatalog(generate.catalog_spec), generate, db_path);
}

// Their training, every room a training room.
VoteNetTrainingOptions FourFrameTraining() {
  VoteNetTrainingOptions training = TinyTraining();
  training.frames_per_room = 4;
  training.validation_share = 0;
  return training;
}

// Fused training frames (issue 37): with share 1 every frame is rasterised
// with its room-mates' points and targets the objects any of them sees; with
// share 0.5 each frame is one or the other, the same on every read; share 0
// is the frames alone and leaves the training's key as it was.
TEST(FusedTraining, FramesAreSeenWithTheirRoomMatesOnRequest) {
  const std::string dir = testing::ScratchDir();
  WriteFourFrameRooms(dir + "/rooms.db");
  const VoteNetTrainingOptions alone = FourFrameTraining();
  VoteNetTrainingOptions fused = alone, half = alone;
  fused.fused_share = 1;
  half.fused_share = 0.5;
  std::vector<BevSample> single, all_fused, mixed, mixed_again;
  ReadBevSamples(dir + "/rooms.db", alone, &single, nullptr);
  ReadBevSamples(dir + "/rooms.db", fused, &all_fused, nullptr);
  ReadBevSamples(dir + "/rooms.db", half, &mixed, nullptr);
  ReadBevSamples(dir + "/rooms.db", half, &mixed_again, nullptr);
  ASSERT_EQ(single.size(), 8u);
  ASSERT_EQ(all_fused.size(), 8u);
  ASSERT_EQ(mixed.size(), 8u);
  auto points = [](const BevSample& sample) {  // the count channels' sum
    double sum = 0;
    const int cells = sample.image.spec.rows * sample.image.spec.cols;
    for (int i = 0; i < kBevTopChannel * cells; ++i) sum += sample.image.values[i];
    return sum;
  };
  int more_points = 0, more_objects = 0, fused_frames = 0;
  for (size_t k = 0; k < single.size(); ++k) {
    EXPECT_GE(points(all_fused[k]), points(single[k]) - 1e-3) << "frame " << k;
    more_points += points(all_fused[k]) > points(single[k]) + 1;
    EXPECT_GE(all_fused[k].objects.size(), single[k].objects.size()) << "frame " << k;
    more_objects += all_fused[k].objects.size() > single[k].objects.size();
    const bool is_fused = mixed[k].image.values == all_fused[k].image.values;
    EXPECT_TRUE(is_fused || mixed[k].image.values == single[k].image.values) << "frame " << k;
    EXPECT_EQ(mixed[k].objects.size(), (is_fused ? all_fused : single)[k].objects.size());
    EXPECT_EQ(mixed[k].image.values, mixed_again[k].image.values) << "frame " << k;
    fused_frames += is_fused;
  }
  EXPECT_GT(more_points, 4) << "room-mates add points to most frames";
  EXPECT_GT(more_objects, 0) << "some object is seen by a room-mate only";
  EXPECT_GT(fused_frames, 0);
  EXPECT_LT(fused_frames, 8);

  EXPECT_EQ(alone.Json().find("fused_share"), std::string::npos) << "older keys stay valid";
  EXPECT_NE(half.Json(), alone.Json());
  VoteNetTrainingOptions bad = alone;
  bad.fused_share = 1.5;
  EXPECT_NE(testing::ErrorOf([&] { bad.Check(); }).find("fused share 1.5"), std::string::npos);
  bad.fused_share = 0.5;
  bad.frames_per_room = 1;
  EXPECT_NE(testing::ErrorOf([&] { bad.Check(); }).find("two or more frames"), std::string::npos);
}

// Fused training frames with odometry's pose error: the room-mates' points
// move, the frame's own and the targets do not, the same on every read.
TEST(FusedTraining, RoomMatesCanCarryAPoseError) {
  const std::string dir = testing::ScratchDir();
  WriteFourFrameRooms(dir + "/rooms.db");
  VoteNetTrainingOptions exact = FourFrameTraining();
  exact.fused_share = 1;
  VoteNetTrainingOptions noisy = exact;
  noisy.fused_pose_noise_m = 0.05;
  noisy.fused_pose_noise_deg = 2;
  std::vector<BevSample> sharp, blurred, blurred_again;
  ReadBevSamples(dir + "/rooms.db", exact, &sharp, nullptr);
  ReadBevSamples(dir + "/rooms.db", noisy, &blurred, nullptr);
  ReadBevSamples(dir + "/rooms.db", noisy, &blurred_again, nullptr);
  ASSERT_EQ(sharp.size(), 8u);
  ASSERT_EQ(blurred.size(), 8u);
  int moved = 0;
  for (size_t k = 0; k < sharp.size(); ++k) {
    moved += blurred[k].image.values != sharp[k].image.values;
    EXPECT_EQ(blurred[k].image.values, blurred_again[k].image.values) << "frame " << k;
    ASSERT_EQ(blurred[k].objects.size(), sharp[k].objects.size()) << "frame " << k;
    for (size_t i = 0; i < sharp[k].objects.size(); ++i)
      EXPECT_EQ(blurred[k].objects[i].Centre(), sharp[k].objects[i].Centre()) << "frame " << k;
  }
  EXPECT_EQ(moved, 8) << "every fused frame's room-mates moved";

  EXPECT_EQ(exact.Json().find("fused_pose_noise"), std::string::npos) << "older keys stay valid";
  EXPECT_NE(noisy.Json(), exact.Json());
  VoteNetTrainingOptions bad = noisy;
  bad.fused_share = 0;
  EXPECT_NE(testing::ErrorOf([&] { bad.Check(); }).find("needs fused frames"), std::string::npos);
  bad = noisy;
  bad.fused_pose_noise_m = 2;
  const std::string error = testing::ErrorOf([&] { bad.Check(); });
  EXPECT_NE(error.find("fused pose noise 2"), std::string::npos) << error;
  FrameFusion parsed;
  EXPECT_NE(testing::ErrorOf([&] {
              ParsePoseNoise("0.02", &parsed, "--vote-fused-pose-noise");
            }).find("--vote-fused-pose-noise '0.02' must be"),
            std::string::npos);
}

}  // namespace
}  // namespace furn
