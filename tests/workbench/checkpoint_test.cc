// The vote network's training checkpoint as a file: what is written reads
// back field for field; another training's (fingerprint), a damaged or cut
// one, or something else altogether is not resumed from, with a note — and
// none of them costs more memory than its own bytes.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/util/file_util.h"
#include "tests/test_util.h"
#include "workbench/pipelines/vote_net_checkpoint.h"

namespace furn {
namespace {

VoteNetCheckpoint Sample() {
  VoteNetCheckpoint c;
  c.fingerprint = "0123456789abcdef0123456789abcdef";
  c.epochs_done = 2;
  c.steps_done = 30;
  c.generator = "12 34 56";
  c.net = std::string("net\0bytes", 9);
  c.adam = "adam";
  c.average = "";
  c.average_updates = 0;
  for (int e = 1; e <= 2; ++e) {
    VoteNetEpoch epoch;
    epoch.epoch = e;
    epoch.train_loss = 1.5 / e;
    epoch.validation_map = 0.25 * e;
    epoch.validation_terms.heat = 0.125;
    epoch.last_weights_map = std::nan("");
    c.epochs.push_back(epoch);
  }
  return c;
}

TEST(VoteNetCheckpoint, ReadsBackWhatWasWrittenForItsOwnTrainingOnly) {
  const std::string dir = testing::ScratchDir(), path = dir + "/m.fcm.checkpoint";
  const VoteNetCheckpoint written = Sample();
  WriteCheckpoint(path, written);
  const std::optional<VoteNetCheckpoint> read = ReadCheckpoint(path, written.fingerprint, true);
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(read->epochs_done, 2);
  EXPECT_EQ(read->steps_done, 30u);
  EXPECT_EQ(read->generator, written.generator);
  EXPECT_EQ(read->net, written.net);
  EXPECT_EQ(read->adam, "adam");
  ASSERT_EQ(read->epochs.size(), 2u);
  EXPECT_EQ(read->epochs[1].validation_map, 0.5);
  EXPECT_EQ(read->epochs[0].validation_terms.heat, 0.125);
  EXPECT_TRUE(std::isnan(read->epochs[0].last_weights_map));
  // Another training's, a cut one, a damaged count, something else: none.
  EXPECT_FALSE(ReadCheckpoint(path, "another fingerprint", true).has_value());
  const std::string bytes = ReadFileBytes(path);
  for (size_t cut : {size_t{3}, size_t{20}, bytes.size() / 2, bytes.size() - 1}) {
    WriteFileAtomically(dir + "/cut", bytes.substr(0, cut));
    EXPECT_FALSE(ReadCheckpoint(dir + "/cut", written.fingerprint, true).has_value()) << cut;
  }
  std::string huge = bytes;
  const uint64_t claims = uint64_t{1} << 60;  // the fingerprint's length, as a header might lie
  huge.replace(8, 8, reinterpret_cast<const char*>(&claims), 8);
  WriteFileAtomically(dir + "/huge", huge);
  EXPECT_FALSE(ReadCheckpoint(dir + "/huge", written.fingerprint, true).has_value());
  WriteFileAtomically(dir + "/model", "FURNMODEL and more");
  EXPECT_FALSE(ReadCheckpoint(dir + "/model", written.fingerprint, true).has_value());
  EXPECT_FALSE(ReadCheckpoint(dir + "/missing", written.fingerprint, true).has_value());
  // Members of an ensemble keep their own.
  EXPECT_EQ(MemberCheckpointPath(path, 0), path);
  EXPECT_EQ(MemberCheckpointPath(path, 2), path + ".member2");
}

}  // namespace
}  // namespace furn
