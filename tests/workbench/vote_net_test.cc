// The learned vote network (libtorch): it can fit a handful of rooms almost
// perfectly (a training sanity check), its bytes round-trip, damaged bytes are
// one clear line, and the same seed and threads give the same weights.
#include "core/learned/vote_net.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <random>
#include <string>

#include <filesystem>
#include <set>

#include "core/learned/self_training.h"
#include "core/learned/vote_net_training.h"
#include "core/util/error.h"
#include "db/sqlite.h"
#include "scenes/catalog.h"
#include "tests/scenes/vote_net_only_map.h"
#include "tests/test_util.h"
#include "workbench/pipelines/train.h"
#include "workbench/pipelines/train_vote_net.h"
#include "workbench/pipelines/vote_net_checkpoint.h"

namespace furn {
namespace {

BevGridSpec SmallGrid() {
  BevGridSpec spec;
  spec.cell_m = 0.1;
  spec.rows = 32;
  spec.cols = 32;
  return spec;
}

// A floor-aligned scene seen from (0, 0, 1.2) looking along +x: floor and
// the surfaces of boxes standing for chairs (0.5 m, seat and back) and tables
// (a top at 0.75 m on legs).
BevSample SyntheticRoom(uint64_t seed, const BevGridSpec& spec) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> ahead(0.8, 2.6), side(-1.2, 1.2), turn(-M_PI, M_PI);
  BevFrame frame;  // origin at the sensor, heading 0
  std::vector<Eigen::Vector3f> points;
  for (double u = 0.3; u < 3.2; u += 0.05) {
    for (double v = -1.6; v < 1.6; v += 0.05) points.emplace_back(u, v, 0.0f);
  }
  BevSample sample;
  for (int i = 0; i < 3; ++i) {
    const bool table = i == 0;
    const BevObject object{
        {ahead(random), side(random), turn(random), table ? 1.2 : 0.5, table ? 0.8 : 0.5},
        table ? FurnitureClass::kTable : FurnitureClass::kChair};
    bool overlaps = false;
    for (const BevObject& other : sample.objects)
      overlaps |= (other.Centre() - object.Centre()).norm() < 1.0;
    if (overlaps) continue;
    sample.objects.push_back(object);
    const Eigen::Rotation2Dd rotation(object.yaw);
    for (double a = -0.5; a <= 0.5; a += 0.04) {
      for (double b = -0.5; b <= 0.5; b += 0.04) {
        const Eigen::Vector2d xy =
            object.Centre() + rotation * Eigen::Vector2d(a * object.width, b * object.depth);
        const float top = table ? 0.75f : 0.45f;
        points.emplace_back(xy.x(), xy.y(), top);
        if (!table && a > 0.45) {  // the chair's back
          for (float z = 0.5f; z < 0.9f; z += 0.05f) points.emplace_back(xy.x(), xy.y(), z);
        }
      }
    }
  }
  sample.image = RasteriseBev(points, Eigen::Vector3f(0, 0, 1.2f), frame, spec);
  return sample;
}

VoteNetTrainingOptions SmallTraining() {
  VoteNetTrainingOptions options;
  options.net.grid = SmallGrid();
  options.net.width = 8;
  options.epochs = 100;
  options.batch_size = 4;
  options.learning_rate = 5e-3;
  options.threads = 1;
  // A width-8 toy on 8 rooms depends on its start: with the membership
  // channel's head (issue 37) seed 1 leaves every table's heat at 0.17;
  // seeds 2 and 3 learn them all.
  options.seed = 2;
  return options;
}

std::vector<BevSample> Rooms(int count) {
  std::vector<BevSample> rooms;
  for (int i = 0; i < count; ++i) rooms.push_back(SyntheticRoom(100 + i, SmallGrid()));
  return rooms;
}

TEST(VoteNet, FitsAHandfulOfRoomsAlmostPerfectly) {
  const std::vector<BevSample> rooms = Rooms(8);
  VoteNetTrainingSummary summary;
  const VoteNet net = TrainVoteNetOnSamples(rooms, rooms, SmallTraining(), &summary);
  ASSERT_EQ(summary.epochs.size(), 100u);
  EXPECT_GT(summary.parameters, 10000);
  const double first = summary.epochs.front().train_loss;
  const double last = summary.epochs.back().validation_loss;
  EXPECT_LT(last, first / 5) << "loss " << first << " -> " << last;
  // Every object's class has its strongest heat within a cell of its centre;
  // the regressed footprint (slower to learn) is within 25 % for all but one.
  int found = 0, sized_well = 0, objects = 0;
  for (const BevSample& room : rooms) {
    const BevOutput out = net.Predict(room.image);
    for (const BevObject& object : room.objects) {
      ++objects;
      const Eigen::Vector2d cell = room.image.frame.CellOf(object.Centre(), room.image.spec);
      const int k = static_cast<int>(object.furniture_class);
      const int row = static_cast<int>(cell.x()), col = static_cast<int>(cell.y());
      float best = 0;
      int best_r = -1, best_c = -1;
      for (int r = std::max(0, row - 4); r <= std::min(31, row + 4); ++r) {
        for (int c = std::max(0, col - 4); c <= std::min(31, col + 4); ++c) {
          if (out.At(k, r, c) > best) best = out.At(k, r, c), best_r = r, best_c = c;
        }
      }
      const bool near = std::abs(best_r - row) <= 1 && std::abs(best_c - col) <= 1 && best > 0.3f;
      const double width = std::exp(out.At(bev_channels::kLogSize[0], row, col));
      const bool sized = std::abs(width / object.width - 1) < 0.25;
      found += near;
      sized_well += sized;
      if (!near || !sized)
        std::printf("missed %s at cell %d %d: best %.2f at %d %d, width %.2f of %.2f\n",
                    ClassName(object.furniture_class),
                    row,
                    col,
                    best,
                    best_r,
                    best_c,
                    width,
                    object.width);
    }
  }
  EXPECT_EQ(found, objects);
  EXPECT_GE(sized_well, objects - 1) << sized_well << " of " << objects;
  // On rooms it fits, the operating point keeps every object and little else.
  const OperatingPoint point = VoteNetOperatingPoint(net, rooms);
  for (FurnitureClass c : {FurnitureClass::kChair, FurnitureClass::kTable}) {
    const ClassOperatingPoint& entry = point.classes[static_cast<size_t>(c)];
    EXPECT_GT(entry.targets, 0) << ClassName(c);
    EXPECT_GE(entry.min_score, 0.1) << ClassName(c);
    EXPECT_GE(entry.f1, 0.9) << ClassName(c);
  }
  EXPECT_NE(point.chosen_on.find("8 validation frames"), std::string::npos) << point.chosen_on;
}

// --mirror-average on an untrained network (not mirror-symmetric by chance):
// each averaged channel is the mean of the image's answer and the mirror's
// turned back (columns reversed, the column offset negated), the yaw is the
// image's own, and the mirrored image's averaged heat is the mirror of it.
TEST(VoteNet, MirrorAverageTurnsTheMirrorsAnswerBack) {
  SetTorchThreads(1);
  VoteNetOptions options;
  options.grid = SmallGrid();
  options.width = 8;
  const VoteNet net = VoteNet::Create(options, /*seed=*/3);
  const BevImage image = Rooms(1)[0].image;
  const BevOutput own = net.Predict(image), mirror = net.Predict(image.Mirrored());
  const BevOutput averaged = net.Predict(image, /*mirror_average=*/true);
  const BevOutput averaged_mirror = net.Predict(image.Mirrored(), true);
  namespace ch = bev_channels;
  const int cols = image.spec.cols;
  double largest_difference = 0;
  for (int r = 0; r < image.spec.rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      for (int k = 0; k < ch::kCount; ++k) {
        const bool yaw = k >= ch::kYaw.first && k < ch::kYaw.end();
        const double sign = k == ch::kOffset[1] ? -1 : 1;
        const double expected =
            yaw ? own.At(k, r, c) : (own.At(k, r, c) + sign * mirror.At(k, r, cols - 1 - c)) / 2;
        ASSERT_NEAR(averaged.At(k, r, c), expected, 1e-5) << "channel " << k;
        largest_difference =
            std::max(largest_difference, std::abs(double{own.At(k, r, c)} - expected));
      }
      for (int k = ch::kHeat.first; k < ch::kHeat.end(); ++k)
        ASSERT_NEAR(averaged_mirror.At(k, r, cols - 1 - c), averaged.At(k, r, c), 1e-5);
    }
  }
  EXPECT_GT(largest_difference, 1e-3);  // the average did change something
}

// Validation takes its loss and the answers it decodes from one forward pass
// of a batch (EvaluateVoteNetLoss with outputs): each answer is Predict's for
// that image within float rounding (oneDNN sums a batch of 8 in another
// order than one image: 3e-8 at most here), on one and two threads, for the toy grid
// and the product's (72 x 96, width 16, batch 8); an ensemble's answers are
// refused (its members differ from the first).
TEST(VoteNet, TheLossPassAnswersAsPredictDoes) {
  VoteNetTrainingOptions options = SmallTraining();
  VoteNetOptions product;  // the default grid and width
  float largest_difference = 0;
  for (const VoteNetOptions& net_options : {options.net, product}) {
    std::vector<BevSample> rooms;
    for (int i = 0; i < 8; ++i) rooms.push_back(SyntheticRoom(200 + i, net_options.grid));
    for (const int threads : {1, 2}) {
      SetTorchThreads(threads);
      const VoteNet net = VoteNet::Create(net_options, /*seed=*/5);
      const TrainingBatch batch =
          MakeTrainingBatch(rooms, {0, 1, 2, 3, 4, 5, 6, 7}, {}, net_options.coder);
      std::vector<BevOutput> answers;
      const VoteNetLoss with = EvaluateVoteNetLoss(net, batch, {}, &answers);
      EXPECT_EQ(with.Total(), EvaluateVoteNetLoss(net, batch, {}).Total());
      ASSERT_EQ(answers.size(), rooms.size());
      for (size_t i = 0; i < answers.size(); ++i) {
        const BevOutput own = net.Predict(rooms[i].image);
        ASSERT_EQ(answers[i].values.size(), own.values.size());
        float largest = 0;
        for (size_t k = 0; k < own.values.size(); ++k)
          largest = std::max(largest, std::abs(answers[i].values[k] - own.values[k]));
        EXPECT_LE(largest, 1e-6f) << "image " << i << ", width " << net_options.width << ", "
                                  << threads << " threads";
        largest_difference = std::max(largest_difference, largest);
        EXPECT_EQ(answers[i].spec.rows, own.spec.rows);
        EXPECT_EQ(answers[i].edge_votes, own.edge_votes);
      }
    }
  }
  std::printf("largest difference of a batch's answer from Predict's: %g\n", largest_difference);
  SetTorchThreads(1);
  const std::vector<BevSample> rooms = Rooms(1);
  std::vector<VoteNet> members;
  members.push_back(VoteNet::Create(options.net, 1));
  members.push_back(VoteNet::Create(options.net, 2));
  const VoteNet ensemble = VoteNet::Ensemble(std::move(members), "test");
  std::vector<BevOutput> answers;
  EXPECT_NE(testing::ErrorOf([&] {
              EvaluateVoteNetLoss(
                  ensemble, MakeTrainingBatch(rooms, {0}, {}, options.net.coder), {}, &answers);
            }).find("not an ensemble"),
            std::string::npos);
}

TEST(VoteNet, BytesRoundTripAndDamageIsOneLine) {
  const std::vector<BevSample> rooms = Rooms(2);
  VoteNetTrainingOptions options = SmallTraining();
  options.epochs = 2;
  options.net.coder = BevCoderOptions::Dense();  // stored with the weights
  VoteNetTrainingSummary summary;
  const VoteNet net = TrainVoteNetOnSamples(rooms, {}, options, &summary);
  const std::string bytes = net.Serialize();
  const VoteNet loaded = VoteNet::Deserialize(bytes, "test.fcm");
  EXPECT_EQ(loaded.Serialize(), bytes);
  EXPECT_EQ(loaded.Predict(rooms[0].image).values, net.Predict(rooms[0].image).values);
  EXPECT_TRUE(loaded.Predict(rooms[0].image).dense_votes);
  EXPECT_EQ(loaded.options().grid, SmallGrid());
  EXPECT_TRUE(loaded.options().coder == BevCoderOptions::Dense());

  auto error_of = [](const std::string& damaged) -> std::string {
    try {
      VoteNet::Deserialize(damaged, "test.fcm");
    } catch (const InputError& error) {
      return error.what();
    }
    return "";
  };
  std::string damaged = bytes;
  damaged[bytes.size() / 2] = static_cast<char>(damaged[bytes.size() / 2] ^ 0x5a);
  damaged[bytes.size() / 2 + 1] = static_cast<char>(damaged[bytes.size() / 2 + 1] ^ 0x5a);
  const std::string flipped = error_of(damaged);
  // A flip inside a weight tensor may still load: then its output differs.
  if (!flipped.empty()) {
    EXPECT_EQ(flipped.find('\n'), std::string::npos) << flipped;
    EXPECT_NE(flipped.find("test.fcm"), std::string::npos) << flipped;
  }
  for (const std::string& bad :
       {bytes.substr(0, 20),
        bytes.substr(0, bytes.size() - 100),
        std::string("FURNVNE"),
        bytes + "x",
        std::string(bytes).replace(40, 8, "\xff\xff\xff\xff\xff\xff\xff\xff")}) {
    const std::string message = error_of(bad);
    EXPECT_FALSE(message.empty()) << "accepted " << bad.size() << " bytes";
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_NE(message.find("test.fcm"), std::string::npos) << message;
  }
  std::string garbled_weights = bytes;
  for (size_t i = 100; i < garbled_weights.size(); ++i) garbled_weights[i] = 'z';
  EXPECT_NE(error_of(garbled_weights).find("vote network is corrupt"), std::string::npos);
}

// Where format 9's member count sits (the header's end), and the bytes from
// a header field at `at` to the weight records: what an older format
// without that field (and all after it) lacks.
constexpr size_t kMembersAt = 92;
constexpr size_t kHeaderTailFrom(size_t at) { return kMembersAt + sizeof(uint32_t) - at; }

// The weights are plain tensor records (issue 39): a record is checked
// against the network the header describes before anything is read or
// allocated; a TorchScript archive (formats 2 and 3) is never loaded.
TEST(VoteNet, WeightRecordsAreCheckedBeforeTheyAreRead) {
  VoteNetOptions options;
  options.grid = SmallGrid();
  options.width = 4;
  const std::string bytes = VoteNet::Create(options, 1).Serialize();
  auto error_of = [](const std::string& damaged) {
    return testing::ErrorOf([&] { VoteNet::Deserialize(damaged, "shared.fcm"); });
  };
  // Header: magic 8, version 4, cell 8, rows 4, cols 4, band 8, width 4,
  // dense 4, three doubles 24, range 8, levels 4, edges 4, centre radius 8;
  // the member count at 92, the record count at 96, the first record at 100
  // (name size 4, "e1.conv1.weight" 15, type 1, dims 4, then the sizes).
  constexpr size_t kCount = kMembersAt + 4, kFirst = kMembersAt + 8;
  const std::string first_name = "e1.conv1.weight";
  ASSERT_EQ(bytes.substr(kFirst + 4, first_name.size()), first_name);
  const size_t dims_at = kFirst + 4 + first_name.size() + 1 + 4;
  auto with = [&](size_t at, const auto& value) {
    std::string damaged = bytes;
    std::memcpy(&damaged[at], &value, sizeof(value));
    return damaged;
  };
  // A size declared far beyond the network (16777216 x 8 x 3 x 3).
  EXPECT_NE(
      error_of(with(dims_at, int64_t{16777216})).find("is declared 16777216 along dimension 0"),
      std::string::npos);
  EXPECT_NE(error_of(with(kCount, uint32_t{7})).find("7 weight records"), std::string::npos);
  EXPECT_NE(error_of(with(kFirst, uint32_t{1u << 30})).find("name is too long"), std::string::npos);
  std::string renamed = bytes;
  renamed[kFirst + 4] = '\n';
  const std::string message = error_of(renamed);
  EXPECT_NE(message.find("weight record '?1.conv1.weight'"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos);
  // Every record cut to its first 4 bytes: truncated, never zeros read.
  EXPECT_NE(error_of(bytes.substr(0, kFirst + 4)).find("truncated"), std::string::npos);
  // A weight that is not a number.
  std::string nan = bytes;
  const float not_a_number = std::nanf("");
  std::memcpy(&nan[dims_at + 4 * 8], &not_a_number, sizeof(float));
  EXPECT_NE(error_of(nan).find("is not finite"), std::string::npos);
  // Formats 2 and 3 (TorchScript archives): refused, unread.
  for (uint32_t old : {2u, 3u}) {
    EXPECT_NE(error_of(with(8, old)).find("TorchScript archive, which this build does not load"),
              std::string::npos);
  }
}

// The error of loading `bytes` as "shared.fcm" with the header field at
// `at` overwritten by `value`.
template <typename T>
std::string ErrorWithHeaderField(const std::string& bytes, size_t at, T value) {
  std::string damaged = bytes;
  std::memcpy(&damaged[at], &value, sizeof(value));
  return testing::ErrorOf([&] { VoteNet::Deserialize(damaged, "shared.fcm"); });
}

// The range of points rasterised is stored with the weights (format 5);
// a format-4 block (before the field) reads as the 3 m it was trained on,
// and a range outside (0, 20] m is refused by name.
TEST(VoteNet, RangeIsStoredAndFormatFourReadsAsThreeMetres) {
  VoteNetOptions options;
  options.grid = SmallGrid();
  options.width = 4;
  EXPECT_DOUBLE_EQ(options.range_m, 3.6);  // the grid's forward reach
  options.range_m = 3.3;
  const std::string bytes = VoteNet::Create(options, 1).Serialize();
  EXPECT_DOUBLE_EQ(VoteNet::Deserialize(bytes, "new.fcm").options().range_m, 3.3);

  constexpr size_t kRangeAt = 68;  // after the coder's three doubles; then the levels
  double stored = 0;
  std::memcpy(&stored, &bytes[kRangeAt], sizeof(stored));
  ASSERT_EQ(stored, 3.3);
  std::string format4 =
      bytes.substr(0, kRangeAt) + bytes.substr(kRangeAt + kHeaderTailFrom(kRangeAt));
  const uint32_t four = 4;
  std::memcpy(&format4[8], &four, sizeof(four));
  const VoteNet old = VoteNet::Deserialize(format4, "old.fcm");
  EXPECT_DOUBLE_EQ(old.options().range_m, 3.0);
  EXPECT_DOUBLE_EQ(VoteNet::Deserialize(old.Serialize(), "old.fcm").options().range_m, 3.0);

  for (double bad : {0.0, -1.0, 25.0, std::nan("")}) {
    const std::string message = ErrorWithHeaderField(bytes, kRangeAt, bad);
    EXPECT_NE(message.find("shared.fcm: vote network is corrupt (vote network range"),
              std::string::npos)
        << bad << ": " << message;
  }
}

// The U-Net's halvings are stored with the weights (format 6): a fourth
// level doubles the receptive field; a format-5 block (before the field)
// reads as the three levels it was built with, and levels the grid cannot
// take are refused by name.
TEST(VoteNet, LevelsAreStoredAndFormatFiveReadsAsThree) {
  VoteNetOptions options;
  options.grid = SmallGrid();
  options.width = 4;
  EXPECT_EQ(options.levels, 3);
  const VoteNet three = VoteNet::Create(options, 1);
  options.levels = 4;
  const VoteNet four = VoteNet::Create(options, 1);
  EXPECT_GT(four.Parameters(), three.Parameters());  // e4 and d4
  const std::string bytes = four.Serialize();
  const VoteNet loaded = VoteNet::Deserialize(bytes, "deep.fcm");
  EXPECT_EQ(loaded.options().levels, 4);
  EXPECT_EQ(loaded.Serialize(), bytes);
  const BevImage image = Rooms(1)[0].image;
  const BevOutput a = four.Predict(image), b = loaded.Predict(image);
  ASSERT_EQ(a.values.size(), b.values.size());
  EXPECT_EQ(a.values, b.values);
  EXPECT_EQ(a.values.size(), three.Predict(image).values.size());

  constexpr size_t kLevelsAt = 76;  // after the range
  const std::string three_bytes = three.Serialize();
  int32_t stored = 0;
  std::memcpy(&stored, &three_bytes[kLevelsAt], sizeof(stored));
  ASSERT_EQ(stored, 3);
  std::string format5 =
      three_bytes.substr(0, kLevelsAt) + three_bytes.substr(kLevelsAt + kHeaderTailFrom(kLevelsAt));
  const uint32_t five = 5;
  std::memcpy(&format5[8], &five, sizeof(five));
  const VoteNet old = VoteNet::Deserialize(format5, "old.fcm");
  EXPECT_EQ(old.options().levels, 3);
  EXPECT_EQ(old.Serialize(), three_bytes);  // the upgrade is the same network

  for (int32_t bad : {1, 6, -3}) {
    const std::string message = ErrorWithHeaderField(bytes, kLevelsAt, bad);
    EXPECT_NE(message.find("shared.fcm: vote network is corrupt (vote network levels"),
              std::string::npos)
        << bad << ": " << message;
  }
  options.levels = 5;  // 32 / 2^5 = 1 cell: still a grid
  EXPECT_NO_THROW(VoteNet::Create(options, 1));
  options.grid.rows = 16;
  EXPECT_NE(testing::ErrorOf([&] { VoteNet::Create(options, 1); }).find("cannot be halved 5 times"),
            std::string::npos);
  // The grid is tied to the range (issue 68: a file's 1024 x 1024 grid on the
  // same weights cost 17 s a frame).
  options.levels = 3;
  options.grid.cell_m = 0.05;
  options.grid.rows = options.grid.cols = 1024;
  EXPECT_NE(testing::ErrorOf([&] {
              VoteNet::Create(options, 1);
            }).find("must reach at most the range (3.6"),
            std::string::npos);
  options.grid.rows = 72;
  options.grid.cols = 96;
  options.range_m = 1;  // a shorter range keeps the default grid
  EXPECT_NO_THROW(VoteNet::Create(options, 1));
}

// Edge votes are stored with the weights (format 7): four more output
// channels, trained (the edges loss term falls), kept through a round trip,
// averaged with the mirror's with the column sides swapped; a format-6 block
// (before the flag) reads as a network without them, and a flag other than 0
// or 1 is refused by name.
TEST(VoteNet, EdgeVotesAreStoredTrainedAndMirrored) {
  const std::vector<BevSample> rooms = Rooms(2);
  VoteNetTrainingOptions options = SmallTraining();
  options.epochs = 3;
  options.net.coder.edge_votes = true;
  VoteNetTrainingSummary summary;
  const VoteNet net = TrainVoteNetOnSamples(rooms, {}, options, &summary);
  ASSERT_TRUE(net.options().coder.edge_votes);
  const TrainingBatch batch = MakeTrainingBatch(rooms, {0, 1}, {}, options.net.coder);
  ASSERT_EQ(batch.targets[0].channels, bev_channels::kCountWithEdges);
  const double trained = EvaluateVoteNetLoss(net, batch, {}).edges;
  VoteNetOptions fresh_options = options.net;
  const double untrained = EvaluateVoteNetLoss(VoteNet::Create(fresh_options, 1), batch, {}).edges;
  EXPECT_GT(trained, 0);
  EXPECT_LT(trained, untrained);

  const std::string bytes = net.Serialize();
  const VoteNet loaded = VoteNet::Deserialize(bytes, "edges.fcm");
  EXPECT_TRUE(loaded.options().coder.edge_votes);
  EXPECT_EQ(loaded.Serialize(), bytes);
  const BevImage image = rooms[0].image;
  const BevOutput own = net.Predict(image), mirror = net.Predict(image.Mirrored());
  const BevOutput averaged = net.Predict(image, /*mirror_average=*/true);
  ASSERT_TRUE(averaged.edge_votes);
  ASSERT_EQ(averaged.values.size(),
            static_cast<size_t>(bev_channels::kCountWithEdges) * image.spec.rows * image.spec.cols);
  namespace ch = bev_channels;
  const int cols = image.spec.cols;
  for (int r = 0; r < image.spec.rows; r += 3) {
    for (int c = 0; c < cols; c += 3) {
      const int swapped[4] = {0, 1, 3, 2};  // the mirror's col min is the image's col max
      for (int side = 0; side < 4; ++side) {
        const double expected = (own.At(ch::kEdges[side], r, c) +
                                 mirror.At(ch::kEdges[swapped[side]], r, cols - 1 - c)) /
                                2;
        ASSERT_NEAR(averaged.At(ch::kEdges[side], r, c), expected, 1e-5) << "side " << side;
      }
    }
  }

  constexpr size_t kEdgesAt = 80;  // after the levels
  int32_t stored = 0;
  std::memcpy(&stored, &bytes[kEdgesAt], sizeof(stored));
  ASSERT_EQ(stored, 1);
  VoteNetOptions plain = options.net;
  plain.coder.edge_votes = false;
  const std::string plain_bytes = VoteNet::Create(plain, 1).Serialize();
  std::string format6 =
      plain_bytes.substr(0, kEdgesAt) + plain_bytes.substr(kEdgesAt + kHeaderTailFrom(kEdgesAt));
  const uint32_t six = 6;
  std::memcpy(&format6[8], &six, sizeof(six));
  const VoteNet old = VoteNet::Deserialize(format6, "old.fcm");
  EXPECT_FALSE(old.options().coder.edge_votes);
  EXPECT_EQ(old.Serialize(), plain_bytes);
  for (int32_t bad : {2, -1}) {
    const std::string message = ErrorWithHeaderField(bytes, kEdgesAt, bad);
    EXPECT_NE(message.find("shared.fcm: vote network is corrupt (edge votes flag)"),
              std::string::npos)
        << bad << ": " << message;
  }
}

// The centre cells' radius is stored with the weights (format 8); a
// format-7 block (before the field) reads as the centre cell alone, and a
// radius outside 0..10 cells is refused by name.
TEST(VoteNet, CentreRadiusIsStoredAndFormatSevenReadsAsTheCentreCell) {
  VoteNetOptions options;
  options.grid = SmallGrid();
  options.width = 4;
  options.coder.centre_radius_cells = 1.5;
  const std::string bytes = VoteNet::Create(options, 1).Serialize();
  EXPECT_EQ(VoteNet::Deserialize(bytes, "radius.fcm").options().coder.centre_radius_cells, 1.5);
  constexpr size_t kRadiusAt = 84;  // after the edge votes flag
  double stored = 0;
  std::memcpy(&stored, &bytes[kRadiusAt], sizeof(stored));
  ASSERT_EQ(stored, 1.5);
  options.coder.centre_radius_cells = 0;
  const std::string plain = VoteNet::Create(options, 1).Serialize();
  std::string format7 =
      plain.substr(0, kRadiusAt) + plain.substr(kRadiusAt + kHeaderTailFrom(kRadiusAt));
  const uint32_t seven = 7;
  std::memcpy(&format7[8], &seven, sizeof(seven));
  const VoteNet old = VoteNet::Deserialize(format7, "old.fcm");
  EXPECT_EQ(old.options().coder.centre_radius_cells, 0);
  EXPECT_EQ(old.Serialize(), plain);
  for (double bad : {-1.0, 11.0, std::nan("")}) {
    const std::string message = ErrorWithHeaderField(bytes, kRadiusAt, bad);
    EXPECT_NE(message.find("shared.fcm: vote network is corrupt (BEV centre radius"),
              std::string::npos)
        << bad << ": " << message;
  }
}

double LargestDifference(const BevOutput& x, const BevOutput& y) {
  double worst = 0;
  for (size_t i = 0; i < x.values.size(); ++i)
    worst = std::max(worst, static_cast<double>(std::abs(x.values[i] - y.values[i])));
  return worst;
}

TEST(VoteNet, SameSeedAndThreadsSameWeights) {
  const std::vector<BevSample> rooms = Rooms(3);
  VoteNetTrainingOptions options = SmallTraining();
  options.epochs = 3;
  VoteNetTrainingSummary a_summary, b_summary;
  const std::string a = TrainVoteNetOnSamples(rooms, {}, options, &a_summary).Serialize();
  const std::string b = TrainVoteNetOnSamples(rooms, {}, options, &b_summary).Serialize();
  EXPECT_EQ(a, b) << "one thread: the same bytes";
  options.seed = 3;
  VoteNetTrainingSummary c_summary;
  EXPECT_NE(TrainVoteNetOnSamples(rooms, {}, options, &c_summary).Serialize(), a);
  // Two threads: libtorch's CPU kernels split reductions by thread, so the
  // weights may differ in the last bits; outputs agree within 1e-3.
  options.seed = 2;
  options.threads = 2;
  VoteNetTrainingSummary d_summary;
  const VoteNet two = TrainVoteNetOnSamples(rooms, {}, options, &d_summary);
  const VoteNet one = VoteNet::Deserialize(a, "a");
  EXPECT_LT(LargestDifference(one.Predict(rooms[0].image), two.Predict(rooms[0].image)), 1e-3);
}

// An environment variable set for a scope, restored after (unset if it was).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value != nullptr) {
      setenv(name, value, 1);
    } else {
      unsetenv(name);
    }
  }
  ~ScopedEnv() {
    if (old_) {
      setenv(name_, old_->c_str(), 1);
    } else {
      unsetenv(name_);
    }
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

// Issue 70: auto is bfloat16 exactly where the CPU has AMX-BF16 (and
// oneDNN may use it), FURN_NETWORK_PRECISION replaces auto (the suite pins
// fp32 with it), and bf16 asked of a CPU without it is one clear line.
TEST(NetworkPrecision, AutoFollowsTheCpuAndTheEnvironment) {
  EXPECT_EQ(ResolvePrecision(NetworkPrecision::kFloat32), NetworkPrecision::kFloat32);
  {
    const ScopedEnv unset("FURN_NETWORK_PRECISION", nullptr);
    EXPECT_EQ(ResolvePrecision(NetworkPrecision::kAuto),
              CpuHasAmxBf16() ? NetworkPrecision::kBfloat16 : NetworkPrecision::kFloat32);
    {
      const ScopedEnv capped("DNNL_MAX_CPU_ISA", "AVX2");  // as the [torch-avx2] variants run
      EXPECT_FALSE(CpuHasAmxBf16());
      EXPECT_FALSE(CpuHasBf16());
      EXPECT_EQ(ResolvePrecision(NetworkPrecision::kAuto), NetworkPrecision::kFloat32);
      EXPECT_NE(testing::ErrorOf([] {
                  ResolvePrecision(NetworkPrecision::kBfloat16);
                }).find("neither AMX-BF16 nor AVX512-BF16"),
                std::string::npos);
    }
  }
  {
    const ScopedEnv fp32("FURN_NETWORK_PRECISION", "fp32");
    EXPECT_EQ(ResolvePrecision(NetworkPrecision::kAuto), NetworkPrecision::kFloat32);
  }
  {
    const ScopedEnv bad("FURN_NETWORK_PRECISION", "fast");
    EXPECT_EQ(testing::ErrorOf([] { ResolvePrecision(NetworkPrecision::kAuto); }),
              "FURN_NETWORK_PRECISION='fast' must be auto, fp32 or bf16");
    // An explicit choice does not read it.
    EXPECT_EQ(ResolvePrecision(NetworkPrecision::kFloat32), NetworkPrecision::kFloat32);
  }
  EXPECT_EQ(ParseEnum<NetworkPrecision>("bf16"), NetworkPrecision::kBfloat16);
  EXPECT_EQ(EnumName(NetworkPrecision::kFloat32), std::string("fp32"));
  // A network computes in float until told otherwise.
  VoteNet net = VoteNet::Create(SmallTraining().net, 1);
  EXPECT_EQ(net.precision(), NetworkPrecision::kFloat32);
  net.SetPrecision(NetworkPrecision::kFloat32);
  EXPECT_EQ(net.precision(), NetworkPrecision::kFloat32);
}

// Skips a test on a CPU without bfloat16 instructions.
#define SKIP_WITHOUT_BF16()                                                   \
  if (!CpuHasBf16()) GTEST_SKIP() << "this CPU has no bfloat16 instructions"; \
  static_assert(true)

// A trained network's bfloat16 answers are its float answers within
// bfloat16's rounding: the same maxima where the heat is clear, with and
// without the mirror, for one network and an ensemble; the answers are
// float tensors of the same shape, repeatable, and a copy keeps computing
// in float until it is told.
TEST(NetworkPrecision, Bf16AnswersAreFloatsWithinItsRounding) {
  SKIP_WITHOUT_BF16();
  const std::vector<BevSample> rooms = Rooms(8);
  VoteNetTrainingOptions options = SmallTraining();
  options.epochs = 40;
  options.precision = NetworkPrecision::kFloat32;
  VoteNetTrainingSummary summary;
  const VoteNet trained = TrainVoteNetOnSamples(rooms, {}, options, &summary);
  EXPECT_EQ(summary.precision, NetworkPrecision::kFloat32);
  VoteNet bf16 = VoteNet::Deserialize(trained.Serialize(), "copy");
  EXPECT_EQ(bf16.precision(), NetworkPrecision::kFloat32);
  bf16.SetPrecision(NetworkPrecision::kBfloat16);
  EXPECT_EQ(bf16.precision(), NetworkPrecision::kBfloat16);
  EXPECT_EQ(bf16.Serialize(), trained.Serialize()) << "the weights stay float";
  SetTorchThreads(1);
  double largest_heat = 0;
  int same_peaks = 0, peaks = 0;
  for (const BevSample& room : rooms) {
    for (const bool mirror : {false, true}) {
      const BevOutput reference = trained.Predict(room.image, mirror);
      const BevOutput fast = bf16.Predict(room.image, mirror);
      ASSERT_EQ(fast.values.size(), reference.values.size());
      EXPECT_EQ(fast.values, bf16.Predict(room.image, mirror).values) << "repeatable";
      for (const BevObject& object : room.objects) {
        const int k = static_cast<int>(object.furniture_class);
        const Eigen::Vector2d cell = room.image.frame.CellOf(object.Centre(), room.image.spec);
        auto peak = [&](const BevOutput& out) {
          std::pair<float, int> best{-1.0f, -1};
          for (int r = std::max(0, static_cast<int>(cell.x()) - 3);
               r <= std::min(31, static_cast<int>(cell.x()) + 3);
               ++r) {
            for (int c = std::max(0, static_cast<int>(cell.y()) - 3);
                 c <= std::min(31, static_cast<int>(cell.y()) + 3);
                 ++c)
              best = std::max(best, {out.At(k, r, c), r * 32 + c});
          }
          return best.second;
        };
        ++peaks;
        same_peaks += peak(reference) == peak(fast);
      }
      for (int row = 0; row < 32; ++row) {
        for (int col = 0; col < 32; ++col) {
          for (int k = 0; k < kBevClasses; ++k)
            largest_heat = std::max(
                largest_heat,
                static_cast<double>(std::abs(fast.At(k, row, col) - reference.At(k, row, col))));
        }
      }
    }
  }
  std::printf("bf16 against fp32: largest heat difference %.4f, %d of %d peaks in the same cell\n",
              largest_heat,
              same_peaks,
              peaks);
  EXPECT_LT(largest_heat, 0.05);
  EXPECT_GE(same_peaks, peaks - 1);
  // An ensemble computes in its first member's arithmetic, every member.
  std::vector<VoteNet> members;
  members.push_back(VoteNet::Deserialize(trained.Serialize(), "a"));
  members.push_back(VoteNet::Deserialize(trained.Serialize(), "b"));
  members[0].SetPrecision(NetworkPrecision::kBfloat16);
  const VoteNet ensemble = VoteNet::Ensemble(std::move(members), "test");
  EXPECT_EQ(ensemble.precision(), NetworkPrecision::kBfloat16);
  EXPECT_EQ(ensemble.Predict(rooms[0].image).values, bf16.Predict(rooms[0].image).values)
      << "two copies of one network (both in bf16) answer as the network";
}

// Training in bfloat16: the same seed gives the same bytes, it learns the
// rooms as float does, its summary says so, and a checkpoint of it does not
// resume a float training.
TEST(NetworkPrecision, Bf16TrainingIsRepeatableAndLearns) {
  SKIP_WITHOUT_BF16();
  const std::vector<BevSample> rooms = Rooms(8);
  VoteNetTrainingOptions options = SmallTraining();
  options.precision = NetworkPrecision::kBfloat16;
  VoteNetTrainingSummary summary, again;
  const VoteNet net = TrainVoteNetOnSamples(rooms, rooms, options, &summary);
  EXPECT_EQ(summary.precision, NetworkPrecision::kBfloat16);
  EXPECT_EQ(net.precision(), NetworkPrecision::kBfloat16);
  options.epochs = 3;
  EXPECT_EQ(TrainVoteNetOnSamples(rooms, {}, options, &again).Serialize(),
            TrainVoteNetOnSamples(rooms, {}, options, &again).Serialize());
  const double first = summary.epochs.front().train_loss;
  const double last = summary.epochs.back().validation_loss;
  EXPECT_LT(last, first / 5) << "loss " << first << " -> " << last;
  const OperatingPoint point = VoteNetOperatingPoint(net, rooms);
  for (FurnitureClass c : {FurnitureClass::kChair, FurnitureClass::kTable})
    EXPECT_GE(point.classes[static_cast<size_t>(c)].f1, 0.9) << ClassName(c);
  VoteNet as_float = VoteNet::Create(options.net, options.WeightSeed());
  VoteNet as_bf16 = VoteNet::Create(options.net, options.WeightSeed());
  as_bf16.SetPrecision(NetworkPrecision::kBfloat16);
  EXPECT_NE(TrainingFingerprint(rooms, {}, options, as_float),
            TrainingFingerprint(rooms, {}, options, as_bf16));
}

// The weight average's arithmetic, seen through the networks' outputs: at
// decay 0 it becomes the network it follows (weights and batch norm's
// running statistics: the followed network was trained, so its statistics
// are not the fresh ones); following the network it started from leaves it
// as it was.
TEST(VoteNetWeightAverage, DecayZeroTakesTheNetworkAndAFixedPointStays) {
  const std::vector<BevSample> rooms = Rooms(3);
  VoteNetTrainingOptions options = SmallTraining();
  options.epochs = 3;
  VoteNetTrainingSummary summary;
  const VoteNet trained = TrainVoteNetOnSamples(rooms, {}, options, &summary);
  const VoteNet fresh = VoteNet::Create(options.net, 7);
  const BevImage& image = rooms[0].image;
  ASSERT_GT(LargestDifference(fresh.Predict(image), trained.Predict(image)), 1e-2);

  VoteNetWeightAverage taking(fresh, 0.0);
  taking.Update(trained);
  EXPECT_EQ(taking.updates(), 1);
  EXPECT_LT(LargestDifference(taking.average().Predict(image), trained.Predict(image)), 1e-6);

  VoteNetWeightAverage staying(trained, 0.999);
  for (int i = 0; i < 5; ++i) staying.Update(trained);
  EXPECT_LT(LargestDifference(staying.average().Predict(image), trained.Predict(image)), 1e-5);

  // Half way (decay 0.5, but the first update's is 2 / 11): neither network.
  VoteNetWeightAverage between(fresh, 0.5);
  between.Update(trained);
  EXPECT_GT(LargestDifference(between.average().Predict(image), trained.Predict(image)), 1e-3);
  EXPECT_GT(LargestDifference(between.average().Predict(image), fresh.Predict(image)), 1e-3);

  EXPECT_THROW({ VoteNetWeightAverage refused(fresh, 1.0); }, InputError);
  VoteNetOptions wider = options.net;
  wider.width = 16;
  EXPECT_THROW(taking.Update(VoteNet::Create(wider, 7)), InputError);
}

// Training with a weight average: the steps are the plain training's (its
// last weights are the plain network's bytes), the network returned is the
// average (other bytes, the same on a second run), each epoch reports both
// validation figures, and the options are checked.
TEST(VoteNetWeightAverage, TrainingKeepsTheAverageAndTheLastWeightsOnRequest) {
  const std::vector<BevSample> rooms = Rooms(3);
  VoteNetTrainingOptions options = SmallTraining();
  options.epochs = 3;
  VoteNetTrainingSummary plain_summary;
  const std::string plain =
      TrainVoteNetOnSamples(rooms, rooms, options, &plain_summary).Serialize();
  EXPECT_TRUE(plain_summary.last_weights.empty());
  EXPECT_TRUE(std::isnan(plain_summary.epochs.back().last_weights_map));

  options.weight_average = 0.9;
  options.keep_last_weights = true;
  VoteNetTrainingSummary a, b;
  const std::string averaged = TrainVoteNetOnSamples(rooms, rooms, options, &a).Serialize();
  EXPECT_EQ(a.last_weights, plain) << "averaging must not change the steps";
  EXPECT_NE(averaged, plain);
  EXPECT_EQ(TrainVoteNetOnSamples(rooms, rooms, options, &b).Serialize(), averaged);
  ASSERT_EQ(a.epochs.size(), 3u);
  EXPECT_DOUBLE_EQ(a.epochs.back().last_weights_map, plain_summary.epochs.back().validation_map);
  EXPECT_NE(a.epochs.back().validation_loss, plain_summary.epochs.back().validation_loss);

  options.weight_average = 1.0;
  EXPECT_THROW(options.Check(), InputError);
  options.weight_average = 0;
  EXPECT_THROW(options.Check(), InputError) << "the last weights without an average";
  EXPECT_EQ(LastWeightsModelPath("out/model.fcm"), "out/model.last.fcm");
  EXPECT_EQ(LastWeightsModelPath("model"), "model.last.fcm");
}

// An ensemble member (VoteNetTrainingOptions::member) trains on the same
// rooms with its own weights and batches; member 0 is the plain training.
TEST(VoteNetEnsemble, MembersAreTheirOwnTrainingsOfTheSameRooms) {
  const std::vector<BevSample> rooms = Rooms(2);
  VoteNetTrainingOptions options = SmallTraining();
  options.epochs = 2;
  VoteNetTrainingSummary summary;
  const std::string plain = TrainVoteNetOnSamples(rooms, {}, options, &summary).Serialize();
  EXPECT_EQ(options.WeightSeed(), options.seed);
  options.member = 1;
  const std::string member = TrainVoteNetOnSamples(rooms, {}, options, &summary).Serialize();
  EXPECT_NE(member, plain);
  EXPECT_EQ(TrainVoteNetOnSamples(rooms, {}, options, &summary).Serialize(), member);
  EXPECT_NE(options.WeightSeed(), options.seed + 1) << "member 1 must not be seed + 1's plain";
  VoteNetTrainingOptions plain_options = SmallTraining();
  EXPECT_EQ(plain_options.Json().find("\"member\":"), std::string::npos)
      << "keys of old models hold";
  EXPECT_NE(options.Json(), plain_options.Json());
  options.member = -1;
  EXPECT_THROW(options.Check(), InputError);

  // `--vote-ensemble 2`: members 0 and 1 of these rooms, combined; the
  // summary holds each member's validation figure and the ensemble's.
  options.member = 0;
  options.ensemble = 2;
  VoteNetTrainingSummary ensemble_summary;
  const VoteNet ensemble = TrainVoteNetEnsemble(rooms, rooms, options, &ensemble_summary);
  EXPECT_EQ(ensemble.Members(), 2);
  std::vector<VoteNet> by_hand;
  by_hand.push_back(VoteNet::Deserialize(plain, "member 0"));
  by_hand.push_back(VoteNet::Deserialize(member, "member 1"));
  EXPECT_EQ(ensemble.Serialize(), VoteNet::Ensemble(std::move(by_hand), "pair").Serialize());
  ASSERT_EQ(ensemble_summary.member_validation_maps.size(), 1u);
  EXPECT_FALSE(std::isnan(ensemble_summary.ensemble_validation_map));
  EXPECT_EQ(ensemble_summary.parameters, ensemble.Parameters());
  EXPECT_NE(options.Json().find("\"ensemble\":2"), std::string::npos);
  for (int bad : {0, 9}) {
    options.ensemble = bad;
    EXPECT_THROW(options.Check(), InputError) << bad;
  }
  options.ensemble = 2;
  options.weight_average = 0.9;
  options.keep_last_weights = true;
  EXPECT_NE(testing::ErrorOf([&] { options.Check(); }).find("not beside an ensemble"),
            std::string::npos);
}

// An ensemble's Predict: without the mirror, every channel but the yaw is
// the members' mean on the image; with it, member 1 answers the mirror, so
// two members cost one network's two passes; an ensemble of a network with
// itself is that network's mirror average. The file keeps every member.
TEST(VoteNetEnsemble, AveragesItsMembersAndIsStoredWhole) {
  SetTorchThreads(1);
  VoteNetOptions options;
  options.grid = SmallGrid();
  options.width = 4;
  const VoteNet a = VoteNet::Create(options, 1), b = VoteNet::Create(options, 2);
  auto copy = [](const VoteNet& net) { return VoteNet::Deserialize(net.Serialize(), "copy"); };
  std::vector<VoteNet> members;
  members.push_back(copy(a));
  members.push_back(copy(b));
  const VoteNet ensemble = VoteNet::Ensemble(std::move(members), "pair.fcm");
  EXPECT_EQ(ensemble.Members(), 2);
  EXPECT_EQ(ensemble.Parameters(), 2 * a.Parameters());

  const BevImage image = Rooms(1)[0].image;
  const BevOutput own_a = a.Predict(image), own_b = b.Predict(image);
  const BevOutput mirror_b = b.Predict(image.Mirrored());
  const BevOutput plain = ensemble.Predict(image), mirrored = ensemble.Predict(image, true);
  namespace ch = bev_channels;
  const int cols = image.spec.cols;
  for (int r = 0; r < image.spec.rows; r += 2) {
    for (int c = 0; c < cols; c += 2) {
      for (int k = 0; k < ch::kCount; ++k) {
        const bool yaw = k >= ch::kYaw.first && k < ch::kYaw.end();
        const double sign = k == ch::kOffset[1] ? -1 : 1;
        const double both = yaw ? own_a.At(k, r, c) : (own_a.At(k, r, c) + own_b.At(k, r, c)) / 2;
        ASSERT_NEAR(plain.At(k, r, c), both, 1e-5) << "channel " << k;
        const double turned =
            yaw ? own_a.At(k, r, c)
                : (own_a.At(k, r, c) + sign * mirror_b.At(k, r, cols - 1 - c)) / 2;
        ASSERT_NEAR(mirrored.At(k, r, c), turned, 1e-5) << "channel " << k;
      }
    }
  }
  EXPECT_GT(LargestDifference(plain, own_a), 1e-3);

  std::vector<VoteNet> twins;
  twins.push_back(copy(a));
  twins.push_back(copy(a));
  EXPECT_LT(LargestDifference(VoteNet::Ensemble(std::move(twins), "twins").Predict(image, true),
                              a.Predict(image, true)),
            1e-5);

  const std::string bytes = ensemble.Serialize();
  const VoteNet loaded = VoteNet::Deserialize(bytes, "pair.fcm");
  EXPECT_EQ(loaded.Members(), 2);
  EXPECT_EQ(loaded.Serialize(), bytes);
  EXPECT_EQ(loaded.Predict(image, true).values, mirrored.values);
  EXPECT_EQ(VoteNet::Deserialize(a.Serialize(), "one").Members(), 1);
}

// What cannot be an ensemble is refused by name, in one line: members of
// other options, an ensemble inside one, none; a file's member count outside
// 1..8 or members missing; and an ensemble does not train.
TEST(VoteNetEnsemble, BadMembersAndCountsAreRefused) {
  VoteNetOptions options;
  options.grid = SmallGrid();
  options.width = 4;
  VoteNetOptions wider = options;
  wider.width = 8;
  auto error_of = [](auto&& make) { return testing::ErrorOf(make); };
  EXPECT_NE(error_of([&] {
              std::vector<VoteNet> members;
              members.push_back(VoteNet::Create(options, 1));
              members.push_back(VoteNet::Create(wider, 2));
              VoteNet::Ensemble(std::move(members), "mixed.fcm");
            }).find("mixed.fcm: ensemble member 2 differs from member 1"),
            std::string::npos);
  EXPECT_NE(error_of([&] { VoteNet::Ensemble({}, "none.fcm"); }).find("1..8 members, not 0"),
            std::string::npos);
  std::vector<VoteNet> pair;
  pair.push_back(VoteNet::Create(options, 1));
  pair.push_back(VoteNet::Create(options, 2));
  VoteNet ensemble = VoteNet::Ensemble(std::move(pair), "pair");
  const std::string bytes = ensemble.Serialize();
  EXPECT_NE(error_of([&] {
              std::vector<VoteNet> nested;
              nested.push_back(VoteNet::Deserialize(bytes, "pair"));
              VoteNet::Ensemble(std::move(nested), "nested.fcm");
            }).find("must be a single network"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              VoteNetOptimizer optimizer(&ensemble, {});
            }).find("an ensemble of vote networks cannot train"),
            std::string::npos);
  for (uint32_t bad : {0u, 9u, 1u << 31}) {
    const std::string message = ErrorWithHeaderField(bytes, kMembersAt, bad);
    EXPECT_NE(message.find("shared.fcm: vote network is corrupt (" + std::to_string(bad) +
                           " ensemble members; 1..8 are readable)"),
              std::string::npos)
        << message;
  }
  // A single network's bytes claiming eight members: the second is missing.
  const std::string one = VoteNet::Create(options, 1).Serialize();
  const std::string message = ErrorWithHeaderField(one, kMembersAt, uint32_t{8});
  EXPECT_NE(message.find("shared.fcm: vote network is truncated (member 2 of 8)"),
            std::string::npos)
      << message;
  EXPECT_EQ(message.find('\n'), std::string::npos);
  const std::string cut = testing::ErrorOf(
      [&] { VoteNet::Deserialize(bytes.substr(0, bytes.size() - 10), "cut.fcm"); });
  EXPECT_NE(cut.find("cut.fcm: vote network is truncated"), std::string::npos) << cut;
}

// The images with every value scaled: a sensor that sees the same rooms
// with a sparser return (the cells' point counts and heights' weights all
// lower), the kind of shift batch normalisation statistics absorb.
std::vector<BevSample> Scaled(std::vector<BevSample> rooms, float scale) {
  for (BevSample& room : rooms)
    for (float& value : room.image.values) value *= scale;
  return rooms;
}

std::vector<const BevImage*> ImagesOf(const std::vector<BevSample>& rooms) {
  std::vector<const BevImage*> images;
  for (const BevSample& room : rooms) images.push_back(&room.image);
  return images;
}

// The mean over the rooms' objects of |heat of `net` on `shown` - heat of
// `reference_net` on the rooms as trained|, at each object's centre cell.
double HeatError(const VoteNet& net,
                 const std::vector<BevSample>& shown,
                 const VoteNet& reference_net,
                 const std::vector<BevSample>& rooms) {
  double error = 0;
  int objects = 0;
  for (size_t i = 0; i < rooms.size(); ++i) {
    const BevOutput out = net.Predict(shown[i].image);
    const BevOutput reference = reference_net.Predict(rooms[i].image);
    for (const BevObject& object : rooms[i].objects) {
      const Eigen::Vector2d cell =
          rooms[i].image.frame.CellOf(object.Centre(), rooms[i].image.spec);
      const int k = static_cast<int>(object.furniture_class);
      const int row = static_cast<int>(cell.x()), col = static_cast<int>(cell.y());
      error += std::abs(out.At(k, row, col) - reference.At(k, row, col));
      ++objects;
    }
  }
  return error / objects;
}

// AdaBN (issue 69): on the same rooms seen by a sparser sensor (every value
// x 0.4) the trained network's heat at the objects drifts; its statistics
// re-estimated on those images (no label) bring it back near the heat it
// gives the rooms it was trained on. blend 0 changes no byte; the same images
// in the same order give the same bytes; blend 0.5 lands between.
TEST(VoteNetAdaptation, StatisticsReestimatedOnShiftedImagesRestoreTheHeat) {
  SetTorchThreads(1);
  const std::vector<BevSample> rooms = Rooms(8);
  VoteNetTrainingSummary summary;
  VoteNetTrainingOptions training = SmallTraining();
  training.epochs = 60;
  const VoteNet trained = TrainVoteNetOnSamples(rooms, rooms, training, &summary);
  const std::vector<BevSample> sparse = Scaled(rooms, 0.4f);
  const std::string bytes = trained.Serialize();

  VoteNet kept = VoteNet::Deserialize(bytes, "kept");
  const NormalisationShift none = AdaptNormalisation(&kept, ImagesOf(sparse), 4, 0.0);
  EXPECT_TRUE(kept.Serialize() == bytes) << "blend 0 changed the network";
  EXPECT_EQ(none.mean_shift_sd, 0.0);
  EXPECT_NEAR(none.variance_ratio, 1.0, 1e-9);
  EXPECT_GT(none.layers, 10);
  EXPECT_EQ(none.images, 8);

  VoteNet adapted = VoteNet::Deserialize(bytes, "adapted");
  const NormalisationShift full = AdaptNormalisation(&adapted, ImagesOf(sparse), 4, 1.0);
  EXPECT_LT(full.variance_ratio, 1.0) << "a sparser image has less variance";
  const double drift = HeatError(trained, sparse, trained, rooms);
  const double restored = HeatError(adapted, sparse, trained, rooms);
  std::printf("heat error at the objects: unadapted %.3f, adapted %.3f\n", drift, restored);
  EXPECT_GT(drift, 0.1);
  EXPECT_LT(restored, drift / 2);

  VoteNet again = VoteNet::Deserialize(bytes, "again");
  AdaptNormalisation(&again, ImagesOf(sparse), 4, 1.0);
  EXPECT_TRUE(again.Serialize() == adapted.Serialize()) << "the same images gave other bytes";
  VoteNet half = VoteNet::Deserialize(bytes, "half");
  const NormalisationShift halfway = AdaptNormalisation(&half, ImagesOf(sparse), 4, 0.5);
  EXPECT_GT(halfway.variance_ratio, full.variance_ratio);
  EXPECT_LT(halfway.variance_ratio, 1.0);
}

TEST(VoteNetAdaptation, BadArgumentsAreOneLine) {
  VoteNetOptions options;
  options.grid = SmallGrid();
  options.width = 4;
  VoteNet net = VoteNet::Create(options, 1);
  const std::vector<BevSample> rooms = Rooms(2);
  EXPECT_NE(
      testing::ErrorOf([&] { AdaptNormalisation(&net, {}, 4, 1); }).find("at least one image"),
      std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] {
              AdaptNormalisation(&net, ImagesOf(rooms), 1, 1);
            }).find("batches of at least 2 images (got 1)"),
            std::string::npos);
  EXPECT_NE(testing::ErrorOf([&] {
              AdaptNormalisation(&net, ImagesOf(rooms), 4, 1.5);
            }).find("must be in [0, 1]"),
            std::string::npos);
  BevGridSpec other = SmallGrid();
  other.rows = 40;
  const BevSample wrong = SyntheticRoom(3, other);
  EXPECT_NE(testing::ErrorOf([&] {
              AdaptNormalisation(&net, {&wrong.image, &wrong.image}, 2, 1);
            }).find("grid differs from the vote network's"),
            std::string::npos);
}

// A pseudo-labelled scan's background is unknown (issue 69): its targets'
// cell weights stay only around its targets' footprints, mirrored or not; a
// labelled frame's weights are all 1.
TEST(VoteNetAdaptation, AnUnknownBackgroundTrainsOnlyNearTheTargets) {
  BevSample known = SyntheticRoom(7, SmallGrid());
  ASSERT_FALSE(known.objects.empty());
  BevSample unknown = known;
  unknown.background_known = false;
  const std::vector<BevSample> samples = {known, unknown};
  const BevCoderOptions coder;
  for (const char mirrored : {0, 1}) {
    const TrainingBatch batch = MakeTrainingBatch(samples, {0, 1}, {mirrored, mirrored}, coder);
    const BevSample& shown = mirrored ? MirroredSample(unknown) : unknown;
    EXPECT_FALSE(shown.background_known);
    const std::vector<float>& all = batch.targets[0].weight;
    const std::vector<float>& near = batch.targets[1].weight;
    EXPECT_EQ(std::count(all.begin(), all.end(), 1.0f), static_cast<long>(all.size()));
    const BevGridSpec& spec = shown.image.spec;
    int kept = 0;
    for (const BevObject& object : shown.objects) {
      const Eigen::Vector2d cell = shown.image.frame.CellOf(object.Centre(), spec);
      EXPECT_EQ(near[static_cast<int>(cell.x()) * spec.cols + static_cast<int>(cell.y())], 1.0f);
    }
    for (float w : near) kept += w > 0;
    EXPECT_GT(kept, 0);
    EXPECT_LT(kept, static_cast<int>(near.size()) / 2) << "most of the grid is away from them";
  }
}

// The mean over the rooms' objects of `net`'s heat of their class at their
// centre cells in `shown`.
double MeanHeatAtObjects(const VoteNet& net,
                         const std::vector<BevSample>& shown,
                         const std::vector<BevSample>& rooms) {
  double sum = 0;
  int objects = 0;
  for (size_t i = 0; i < rooms.size(); ++i) {
    const BevOutput out = net.Predict(shown[i].image);
    for (const BevObject& object : rooms[i].objects) {
      const Eigen::Vector2d cell =
          rooms[i].image.frame.CellOf(object.Centre(), rooms[i].image.spec);
      sum += out.At(static_cast<int>(object.furniture_class),
                    static_cast<int>(cell.x()),
                    static_cast<int>(cell.y()));
      ++objects;
    }
  }
  return sum / objects;
}

// Self-training (issue 69): on the rooms seen by a sparser sensor (x 0.7) the trained
// network's confident, mirror-consistent maxima are pseudo-targets, and
// every one lies on a true object of its class; thresholds no heat reaches
// leave none (the maxima are ignored, not background). Fine-tuned on them
// beside the original rooms, the network's heat at the sparse rooms'
// objects rises (no label of the sparse rooms was read); the same seed
// gives the same bytes.
TEST(VoteNetAdaptation, SelfTrainingOnItsOwnConfidentMaximaRaisesTheHeatOnShiftedImages) {
  SetTorchThreads(1);
  const std::vector<BevSample> rooms = Rooms(8);
  VoteNetTrainingSummary summary;
  VoteNetTrainingOptions training = SmallTraining();
  training.epochs = 60;
  const VoteNet trained = TrainVoteNetOnSamples(rooms, rooms, training, &summary);
  // x 0.7: the heat at the objects drops to ~0.4 (at x 0.5 confident false
  // tables outnumber the true maxima, and no self-training can recover).
  const std::vector<BevSample> sparse = Scaled(rooms, 0.7f);

  PseudoLabelOptions pseudo;
  pseudo.fallback_min_heat = 0.2;
  PseudoLabelCounts counts;
  std::vector<BevSample> tuning;
  int off_targets = 0;
  for (const BevSample& room : sparse) {
    tuning.push_back(PseudoLabelledSample(trained, room.image, pseudo, &counts));
    const BevSample& truth = rooms[tuning.size() - 1];
    for (const BevObject& label : tuning.back().objects) {
      if (!label.target) continue;
      double nearest = 1e9;
      for (const BevObject& object : truth.objects) {
        if (object.furniture_class == label.furniture_class)
          nearest = std::min(nearest, (object.Centre() - label.Centre()).norm());
      }
      if (nearest >= 0.3) {
        ++off_targets;
        std::printf("%s pseudo-target %.2f m off\n", ClassName(label.furniture_class), nearest);
      }
    }
  }
  EXPECT_EQ(counts.images, 8);
  EXPECT_GE(counts.Targets(), 4) << "ignored " << counts.ignored;
  // Nearly all on a true object: at most 1 in 8 elsewhere (oneDNN's AVX2
  // kernels put none of 20 elsewhere, its AVX-512 ones 2 tables of 23).
  EXPECT_LE(off_targets * 8, counts.Targets()) << off_targets << " pseudo-targets off";

  PseudoLabelOptions unreachable = pseudo;
  unreachable.heat_share = 4;  // a threshold of 1: no sigmoid reaches it
  PseudoLabelCounts none;
  const BevSample ignored = PseudoLabelledSample(trained, sparse[0].image, unreachable, &none);
  EXPECT_EQ(none.Targets(), 0);
  EXPECT_EQ(none.ignored, static_cast<int>(ignored.objects.size()));
  EXPECT_GT(none.ignored, 0);

  for (const BevSample& room : rooms) tuning.push_back(room);
  VoteNetTrainingOptions fine = SmallTraining();
  fine.epochs = 15;
  fine.learning_rate = 1e-3;
  VoteNetTrainingSummary tuned_summary;
  const VoteNet tuned = TrainVoteNetOnSamples(tuning, {}, fine, &tuned_summary, &trained);
  const double before = MeanHeatAtObjects(trained, sparse, rooms);
  const double after = MeanHeatAtObjects(tuned, sparse, rooms);
  std::printf("heat at the sparse rooms' objects: %.3f -> %.3f (%d pseudo-targets)\n",
              before,
              after,
              counts.Targets());
  EXPECT_GT(after, before + 0.05);
  EXPECT_GT(MeanHeatAtObjects(tuned, rooms, rooms), 0.5) << "the rooms it was trained on";
  VoteNetTrainingSummary again_summary;
  const VoteNet again = TrainVoteNetOnSamples(tuning, {}, fine, &again_summary, &trained);
  EXPECT_TRUE(again.Serialize() == tuned.Serialize()) << "the same seed gave other bytes";

  EXPECT_NE(testing::ErrorOf([&] {
              PseudoLabelOptions bad;
              bad.mirror_match_m = 0;
              bad.Check();
            }).find("--mirror-match must be in (0, 2] m"),
            std::string::npos);
  const VoteNet pair = VoteNet::Ensemble(
      [&] {
        std::vector<VoteNet> members;
        members.push_back(VoteNet::Deserialize(trained.Serialize(), "a"));
        members.push_back(VoteNet::Deserialize(trained.Serialize(), "b"));
        return members;
      }(),
      "pair");
  EXPECT_NE(testing::ErrorOf([&] {
              TrainVoteNetOnSamples(tuning, {}, fine, &again_summary, &pair);
            }).find("fine-tuning needs one network"),
            std::string::npos);
}

// A class map's vote-net-only tables and sideboards (here six added to the
// default map) are placed in the vote network's training rooms (and only
// there: the composer's test in class_map_test.cc), and the summary counts
// them.
TEST(VoteNet, TrainingRoomsPlaceTheVoteNetOnlyModels) {
  if (!std::filesystem::exists("/usr/share/sweethome3d/furniture/Scopia.sh3f"))
    GTEST_SKIP() << "sweethome3d-furniture is not installed";
  CatalogOpenOptions open;
  open.allow_procedural_fallback = false;
  const std::string dir = testing::ScratchDir();
  const Catalog catalog = OpenCatalog(testing::WriteDefaultMapWithVoteNetOnlyExtras(dir), open);
  std::set<std::string> extra;
  for (const CatalogEntry* entry : catalog.Classified())
    if (entry->vote_net_only) extra.insert(entry->id);
  ASSERT_EQ(extra.size(), static_cast<size_t>(testing::kVoteNetOnlyExtras));
  VoteNetTrainingOptions options;
  options.rooms = 16;
  options.frames_per_room = 1;
  options.epochs = 1;
  options.net.width = 4;
  options.keep_rooms = true;
  options.quiet = true;
  const std::string rooms = dir + "/rooms.db";
  VoteNetTrainingSummary summary;
  TrainVoteNet(catalog, {}, options, rooms, &summary);
  EXPECT_EQ(summary.vote_net_only_models, static_cast<int>(extra.size()));
  Database db(rooms, Database::Mode::kReadOnly);
  Statement placed(&db, "SELECT DISTINCT model_id FROM objects");
  int extra_placed = 0;
  while (placed.Step()) extra_placed += extra.count(placed.ColumnText(0));
  EXPECT_GT(extra_placed, 0) << "16 rooms and none of the vote-net-only models";
}

}  // namespace
}  // namespace furn
