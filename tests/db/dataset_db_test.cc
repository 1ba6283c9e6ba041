#include "db/dataset_db.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "tests/test_util.h"

namespace furn {
namespace {

RoomRecord MakeRoom(int64_t id, size_t image_bytes) {
  RoomRecord room;
  room.id = id;
  room.seed = 1000 + id;
  room.split = SplitForSeed(room.seed);
  room.width = room.depth = 4;
  ObjectRecord object;
  object.instance_id = 10;
  object.model_id = "m";
  object.furniture_class = FurnitureClass::kChair;
  room.objects.push_back(object);
  for (int j = 0; j < 2; ++j) {
    FrameRecord frame;
    frame.id = id * 2 + j;
    frame.frame_index = j;
    frame.width = 640;
    frame.height = 480;
    // Incompressible bytes, so the pages really fill up.
    for (std::vector<uint8_t>* image :
         {&frame.depth_ideal_png, &frame.depth_noisy_png, &frame.ids_png, &frame.ids_noisy_png}) {
      image->resize(image_bytes);
      for (size_t k = 0; k < image_bytes; ++k)
        (*image)[k] = static_cast<uint8_t>((k * 2654435761u) >> 13);
    }
    frame.content_hash = "h" + std::to_string(frame.id);
    FrameObjectRecord seen;
    seen.instance_id = 10;
    frame.objects.push_back(seen);
    room.frames.push_back(frame);
  }
  return room;
}

TEST(DatasetDb, RoomsRoundTrip) {
  const std::string path = testing::ScratchDir() + "/d.db";
  DatasetDb dataset(path, DatasetDb::Mode::kReadWrite);
  dataset.WriteModels(
      {{"m", FurnitureClass::kChair, "abc", Eigen::Vector3d(0.5, 0.5, 0.9), false}});
  const RoomRecord room = MakeRoom(3, 100);
  dataset.WriteRoom(room);
  EXPECT_TRUE(dataset.HasRoom(3));
  const RoomRecord back = dataset.ReadRoom(3, true);
  EXPECT_EQ(back.seed, room.seed);
  ASSERT_EQ(back.frames.size(), 2u);
  EXPECT_EQ(back.frames[1].depth_noisy_png, room.frames[1].depth_noisy_png);
  EXPECT_EQ(back.objects[0].furniture_class, FurnitureClass::kChair);
  // The same model with another hash means the catalog changed: refused.
  EXPECT_THROW(
      dataset.WriteModels({{"m", FurnitureClass::kChair, "xyz", Eigen::Vector3d::Ones(), false}}),
      DbError);
  EXPECT_THROW(dataset.WriteRoom(room), DbError);  // room 3 exists
}

TEST(DatasetDb, FullDiskFailsCleanlyAndKeepsWholeRooms) {
  const std::string path = testing::ScratchDir() + "/full.db";
  {
    DatasetDb dataset(path, DatasetDb::Mode::kReadWrite);
    dataset.WriteModels(
        {{"m", FurnitureClass::kChair, "abc", Eigen::Vector3d(0.5, 0.5, 0.9), false}});
    dataset.WriteRoom(MakeRoom(0, 20000));
    // A disk that is full after a few more pages, as SQLite sees it.
    Statement pages(dataset.database(), "PRAGMA page_count");
    pages.Step();
    dataset.database()->Execute("PRAGMA max_page_count = " +
                                std::to_string(pages.ColumnInt(0) + 20));
    try {
      dataset.WriteRoom(MakeRoom(1, 200000));
      FAIL() << "the write should not fit";
    } catch (const DbError& error) {
      EXPECT_NE(std::string(error.what()).find("full"), std::string::npos) << error.what();
      EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << error.what();
    }
  }
  DatasetDb reopened(path, DatasetDb::Mode::kReadOnly);
  EXPECT_EQ(reopened.RoomIds(), std::vector<int64_t>{0});
  Statement check(reopened.database(), "PRAGMA integrity_check");
  ASSERT_TRUE(check.Step());
  EXPECT_EQ(check.ColumnText(0), "ok");
  EXPECT_EQ(reopened.ReadRoom(0, false).frames.size(), 2u);
}

TEST(DatasetDb, RemoveDatabaseFilesTakesTheWalAndShmToo) {
  const std::string path = testing::ScratchDir() + "/gone.db";
  { DatasetDb db(path, DatasetDb::Mode::kReadWrite); }
  testing::WriteText(path + "-wal", "x");  // as a killed writer leaves them
  testing::WriteText(path + "-shm", "x");
  RemoveDatabaseFiles(path);
  for (const char* suffix : {"", "-wal", "-shm"})
    EXPECT_FALSE(std::filesystem::exists(path + suffix)) << suffix;
  RemoveDatabaseFiles(path);  // nothing there: no error
}

TEST(DatasetDb, SplitsFollowTheRatios) {
  int counts[3] = {0, 0, 0};
  for (uint64_t seed = 0; seed < 10000; ++seed) {
    const Split split = SplitForSeed(seed * 7919);
    counts[split == Split::kTrain ? 0 : split == Split::kVal ? 1 : 2]++;
  }
  EXPECT_NEAR(counts[0] / 10000.0, 0.6, 0.03);
  EXPECT_NEAR(counts[1] / 10000.0, 0.2, 0.03);
  EXPECT_NEAR(counts[2] / 10000.0, 0.2, 0.03);
}

}  // namespace
}  // namespace furn
