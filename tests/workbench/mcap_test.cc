// MCAP as the specification lays it out: files written here read back with
// every schema, channel and message, in log-time order, with each of the
// three chunk compressions; the summary, its offsets, the chunk and message
// indexes and every CRC checked by a walker written in this test (not by the
// reader under test); and damaged or hostile files refused with one line
// naming the file and the record, within their own size.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <zlib.h>
#include <zstd.h>

#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "core/util/error.h"
#include "core/util/file_util.h"
#include "tests/test_util.h"
#include "workbench/formats/mcap.h"

namespace furn {
namespace {

std::vector<uint8_t> Bytes(const std::string& text) {
  return std::vector<uint8_t>(text.begin(), text.end());
}

template <typename T>
T At(const std::string& bytes, size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}

// Little-endian bytes for hand-built records.
struct Raw {
  std::string bytes;
  template <typename T>
  Raw& Put(T value) {
    bytes.append(reinterpret_cast<const char*>(&value), sizeof(T));
    return *this;
  }
  Raw& Str(const std::string& text) {
    Put<uint32_t>(static_cast<uint32_t>(text.size()));
    bytes += text;
    return *this;
  }
  Raw& Record(uint8_t opcode, const std::string& content) {
    Put<uint8_t>(opcode).Put<uint64_t>(content.size());
    bytes += content;
    return *this;
  }
};

// The process's peak resident memory so far.
double PeakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

std::string Magic() { return std::string(kMcapMagic, kMcapMagicBytes); }

std::string HeaderRecord() {
  Raw content;
  content.Str("ros2").Str("test");
  return Raw().Record(0x01, content.bytes).bytes;
}
std::string SchemaRecord(uint16_t id) {
  Raw content;
  content.Put<uint16_t>(id).Str("pkg/msg/T").Str("ros2msg").Str("int32 a\n");
  return Raw().Record(0x03, content.bytes).bytes;
}
std::string ChannelRecord(uint16_t id, uint16_t schema) {
  Raw content;
  content.Put<uint16_t>(id).Put<uint16_t>(schema).Str("/t").Str("cdr").Put<uint32_t>(0);
  return Raw().Record(0x04, content.bytes).bytes;
}
std::string MessageRecord(uint16_t channel, uint64_t time, const std::string& data) {
  Raw content;
  content.Put<uint16_t>(channel).Put<uint32_t>(0).Put<uint64_t>(time).Put<uint64_t>(time);
  content.bytes += data;
  return Raw().Record(0x05, content.bytes).bytes;
}
std::string ChunkRecord(const std::string& compression,
                        const std::string& stored,
                        uint64_t uncompressed_size,
                        uint32_t crc = 0) {
  Raw content;
  content.Put<uint64_t>(0).Put<uint64_t>(0).Put<uint64_t>(uncompressed_size).Put<uint32_t>(crc);
  content.Str(compression).Put<uint64_t>(stored.size());
  content.bytes += stored;
  return Raw().Record(0x06, content.bytes).bytes;
}
// A file of the given data-section records, an empty summary and a footer.
std::string FileOf(const std::string& records) {
  Raw footer;
  footer.Put<uint64_t>(0).Put<uint64_t>(0).Put<uint32_t>(0);
  return Magic() + HeaderRecord() + records + Raw().Record(0x0F, std::string(4, '\0')).bytes +
         Raw().Record(0x02, footer.bytes).bytes + Magic();
}

class McapTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = testing::ScratchDir(); }
  std::string Write(const std::string& name, const std::string& bytes) {
    const std::string path = dir_ + "/" + name;
    WriteFileAtomically(path, bytes);
    return path;
  }
  // The one line a damaged file gets; it must name the file.
  std::string Refusal(const std::string& bytes) {
    const std::string path = Write("bad.mcap", bytes);
    try {
      McapReader reader(path);
      std::set<uint16_t> all;
      for (const auto& [id, channel] : reader.channels()) all.insert(id);
      reader.ForEach(all, [](const McapMessage&) {});
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(path), std::string::npos) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
      return message;
    }
    ADD_FAILURE() << "accepted";
    return "";
  }
  std::string dir_;
};

// Three channels over two schemas, messages out of time order, split over
// many chunks.
std::string WriteSample(const std::string& path, McapCompression compression, size_t chunk_bytes) {
  McapWriterOptions options;
  options.compression = compression;
  options.chunk_bytes = chunk_bytes;
  McapWriter out(path, options);
  const uint16_t image = out.AddSchema("sensor_msgs/msg/Image", "ros2msg", "uint32 height\n");
  const uint16_t tf = out.AddSchema("tf2_msgs/msg/TFMessage", "ros2msg", "string x\n");
  const uint16_t depth = out.AddChannel(image, "/depth", "cdr", {{"offered_qos_profiles", "- a"}});
  const uint16_t ids = out.AddChannel(image, "/ids", "cdr", {});
  const uint16_t tree = out.AddChannel(tf, "/tf_static", "cdr", {});
  out.Write(tree, 50, Bytes("static"));
  for (uint64_t k = 0; k < 40; ++k) {
    out.Write(depth, 100 + 10 * k, std::vector<uint8_t>(300 + k, static_cast<uint8_t>(k)));
    out.Write(ids, 100 + 10 * k, Bytes("ids " + std::to_string(k)));
  }
  out.Write(depth, 60, Bytes("late"));  // recorded late: read before the others
  EXPECT_EQ(out.Finish(), 82);
  return ReadFileBytes(path);
}

TEST_F(McapTest, FilesWrittenHereReadBackInLogTimeOrderWithEveryCompression) {
  for (McapCompression compression :
       {McapCompression::kNone, McapCompression::kZstd, McapCompression::kLz4}) {
    const std::string path = dir_ + "/sample_" + McapCompressionName(compression) + ".mcap";
    WriteSample(path, compression, 2048);
    McapReader in(path);
    EXPECT_EQ(in.profile(), "ros2");
    EXPECT_EQ(in.compression(), compression);
    EXPECT_EQ(McapReader::FirstChunkCompression(path), compression);
    ASSERT_EQ(in.schemas().size(), 2u);
    EXPECT_EQ(in.schemas().at(1).name, "sensor_msgs/msg/Image");
    EXPECT_EQ(in.schemas().at(1).data, "uint32 height\n");
    ASSERT_EQ(in.channels().size(), 3u);
    EXPECT_EQ(in.channels().at(1).topic, "/depth");
    EXPECT_EQ(in.channels().at(1).metadata.at("offered_qos_profiles"), "- a");
    EXPECT_EQ(in.Count({1}), 41);
    EXPECT_EQ(in.Count({1, 2, 3}), 82);
    std::vector<uint64_t> times;
    std::vector<std::vector<uint8_t>> depth;
    in.ForEach({1, 3}, [&](const McapMessage& m) {
      times.push_back(m.log_time);
      if (m.channel_id == 1) depth.push_back(m.data);
    });
    ASSERT_EQ(times.size(), 42u);
    EXPECT_TRUE(std::is_sorted(times.begin(), times.end()));
    EXPECT_EQ(times.front(), 50u);
    EXPECT_EQ(depth.front(), Bytes("late"));
    EXPECT_EQ(depth.back(), std::vector<uint8_t>(339, 39));
    int limited = 0;
    in.ForEach(
        {2}, [&](const McapMessage&) { ++limited; }, 5);
    EXPECT_EQ(limited, 5);
  }
}

TEST_F(McapTest, TheSameMessagesMakeTheSameBytes) {
  const std::string a = WriteSample(dir_ + "/a.mcap", McapCompression::kZstd, 4096);
  const std::string b = WriteSample(dir_ + "/b.mcap", McapCompression::kZstd, 4096);
  EXPECT_EQ(a, b);
}

// The layout an indexed reader (rosbag2, @mcap/core) relies on, walked here
// from the footer back: summary offsets, groups, chunk indexes pointing at
// chunks, message indexes pointing at messages, statistics, every CRC.
TEST_F(McapTest, TheSummaryIndexesAndCrcsAreThoseOfTheSpecification) {
  const std::string file = WriteSample(dir_ + "/s.mcap", McapCompression::kNone, 2048);
  ASSERT_EQ(file.substr(0, 8), Magic());
  ASSERT_EQ(file.substr(file.size() - 8), Magic());
  const size_t footer = file.size() - 8 - 29;
  ASSERT_EQ(static_cast<uint8_t>(file[footer]), 0x02);
  ASSERT_EQ(At<uint64_t>(file, footer + 1), 20u);
  const uint64_t summary_start = At<uint64_t>(file, footer + 9);
  const uint64_t offsets_start = At<uint64_t>(file, footer + 17);
  const uint32_t summary_crc = At<uint32_t>(file, footer + 25);
  EXPECT_EQ(summary_crc,
            crc32(0,
                  reinterpret_cast<const Bytef*>(file.data() + summary_start),
                  static_cast<uInt>(footer + 25 - summary_start)));
  // The data end record just before the summary, with the data section's CRC.
  ASSERT_EQ(static_cast<uint8_t>(file[summary_start - 13]), 0x0F);
  EXPECT_EQ(
      At<uint32_t>(file, summary_start - 4),
      crc32(0, reinterpret_cast<const Bytef*>(file.data()), static_cast<uInt>(summary_start - 13)));
  // Summary offsets: one per group, each pointing at records of its opcode.
  std::map<uint8_t, std::pair<uint64_t, uint64_t>> groups;
  for (size_t at = offsets_start; at < footer;) {
    ASSERT_EQ(static_cast<uint8_t>(file[at]), 0x0E);
    groups[static_cast<uint8_t>(file[at + 9])] = {At<uint64_t>(file, at + 10),
                                                  At<uint64_t>(file, at + 18)};
    at += 9 + At<uint64_t>(file, at + 1);
  }
  ASSERT_EQ(groups.size(), 4u);  // schemas, channels, statistics, chunk indexes
  uint64_t chunks = 0, indexed_messages = 0;
  for (const auto& [opcode, place] : groups) {
    for (uint64_t at = place.first; at < place.first + place.second;) {
      ASSERT_EQ(static_cast<uint8_t>(file[at]), opcode);
      const uint64_t content = at + 9;
      if (opcode == 0x0B) {  // statistics
        EXPECT_EQ(At<uint64_t>(file, content), 82u);
        EXPECT_EQ(At<uint16_t>(file, content + 8), 2u);
        EXPECT_EQ(At<uint32_t>(file, content + 10), 3u);
        chunks = At<uint32_t>(file, content + 22);
        EXPECT_EQ(At<uint64_t>(file, content + 26), 50u);   // first log time
        EXPECT_EQ(At<uint64_t>(file, content + 34), 490u);  // last
      }
      if (opcode == 0x08) {  // a chunk index
        const uint64_t chunk_at = At<uint64_t>(file, content + 16);
        const uint64_t chunk_length = At<uint64_t>(file, content + 24);
        ASSERT_EQ(static_cast<uint8_t>(file[chunk_at]), 0x06);
        EXPECT_EQ(9 + At<uint64_t>(file, chunk_at + 1), chunk_length);
        // The chunk's records and their CRC.
        const uint64_t size = At<uint64_t>(file, chunk_at + 9 + 16);
        const uint32_t crc = At<uint32_t>(file, chunk_at + 9 + 24);
        const uint64_t records_at = chunk_at + 9 + 28 + 4 + 8;  // compression "" then length
        EXPECT_EQ(crc,
                  crc32(0,
                        reinterpret_cast<const Bytef*>(file.data() + records_at),
                        static_cast<uInt>(size)));
        // Each message index points at message records of its channel.
        const uint32_t map_bytes = At<uint32_t>(file, content + 32);
        for (uint64_t entry = content + 36; entry < content + 36 + map_bytes; entry += 10) {
          const uint16_t channel = At<uint16_t>(file, entry);
          const uint64_t index_at = At<uint64_t>(file, entry + 2);
          ASSERT_EQ(static_cast<uint8_t>(file[index_at]), 0x07);
          EXPECT_EQ(At<uint16_t>(file, index_at + 9), channel);
          const uint32_t array = At<uint32_t>(file, index_at + 11);
          for (uint64_t k = index_at + 15; k < index_at + 15 + array; k += 16) {
            const uint64_t message_at = records_at + At<uint64_t>(file, k + 8);
            ASSERT_EQ(static_cast<uint8_t>(file[message_at]), 0x05);
            EXPECT_EQ(At<uint16_t>(file, message_at + 9), channel);
            EXPECT_EQ(At<uint64_t>(file, message_at + 9 + 6), At<uint64_t>(file, k));
            ++indexed_messages;
          }
        }
      }
      at += 9 + At<uint64_t>(file, at + 1);
    }
  }
  EXPECT_GT(chunks, 5u);
  EXPECT_EQ(indexed_messages, 82u);
}

TEST_F(McapTest, DamagedFilesAreOneLineNamingTheRecord) {
  const std::string good = WriteSample(dir_ + "/good.mcap", McapCompression::kZstd, 2048);
  EXPECT_NE(Refusal("not an mcap file at all, but long enough to hold one").find("no MCAP magic"),
            std::string::npos);
  // Cut where a recorder killed mid-write leaves it.
  EXPECT_NE(Refusal(good.substr(0, good.size() / 2)).find("cut short"), std::string::npos);
  // Cut between records: no footer.
  const std::string whole_records = FileOf(SchemaRecord(1));
  EXPECT_NE(
      Refusal(whole_records.substr(0, whole_records.size() - 8 - 29)).find("without a Footer"),
      std::string::npos);
  // A record whose length runs past the file.
  std::string past = good;
  const uint64_t huge = uint64_t{1} << 40;
  std::memcpy(&past[8 + 1], &huge, 8);
  EXPECT_NE(Refusal(past).find("runs past the file"), std::string::npos);
  // A message on a channel nobody defined; a channel of an undefined schema.
  EXPECT_NE(Refusal(FileOf(SchemaRecord(1) + MessageRecord(7, 1, "x"))).find("channel 7"),
            std::string::npos);
  EXPECT_NE(Refusal(FileOf(ChannelRecord(1, 4))).find("names schema 4"), std::string::npos);
  EXPECT_NE(Refusal(FileOf(SchemaRecord(0))).find("schema id 0"), std::string::npos);
  // Unknown compression; a CRC that does not match.
  const std::string records = SchemaRecord(1) + ChannelRecord(1, 1) + MessageRecord(1, 5, "abc");
  EXPECT_NE(Refusal(FileOf(ChunkRecord("brotli", records, records.size())))
                .find("'brotli' is not none, zstd or lz4"),
            std::string::npos);
  EXPECT_NE(
      Refusal(FileOf(ChunkRecord("", records, records.size(), 12345))).find("uncompressed_crc"),
      std::string::npos);
  // A plain chunk whose records run past its end.
  const std::string overlong = records + Raw().Put<uint8_t>(5).Put<uint64_t>(100).bytes;
  EXPECT_NE(Refusal(FileOf(ChunkRecord("", overlong, overlong.size())))
                .find("a length of 100 bytes runs past the chunk"),
            std::string::npos);
  const std::string stub = records + "\x05";
  EXPECT_NE(Refusal(FileOf(ChunkRecord("", stub, stub.size()))).find("truncated record prefix"),
            std::string::npos);
  // Fine as written.
  const std::string path = Write("ok.mcap", FileOf(ChunkRecord("", records, records.size())));
  McapReader ok(path);
  EXPECT_EQ(ok.Count({1}), 1);
}

// A chunk's header may claim any size; memory follows what really comes out
// of the decompressor, and more than claimed (a bomb) is refused.
TEST_F(McapTest, ChunkSizesAreNeverTakenOnTrust) {
  const std::string records = SchemaRecord(1) + ChannelRecord(1, 1) + MessageRecord(1, 5, "abc");
  std::string zstd(ZSTD_compressBound(records.size()), '\0');
  zstd.resize(ZSTD_compress(zstd.data(), zstd.size(), records.data(), records.size(), 1));
  // Claims 2^40 bytes: refused by the cap before anything is allocated.
  EXPECT_NE(Refusal(FileOf(ChunkRecord("zstd", zstd, uint64_t{1} << 40)))
                .find("uncompressed_size 1099511627776 is more than"),
            std::string::npos);
  // Claims less than it holds: 64 MiB of zeros in a few KB, claiming 100 bytes.
  const std::string zeros(64 << 20, '\0');
  std::string bomb(ZSTD_compressBound(zeros.size()), '\0');
  bomb.resize(ZSTD_compress(bomb.data(), bomb.size(), zeros.data(), zeros.size(), 3));
  ASSERT_LT(bomb.size(), 1u << 16);
  const double peak_before = PeakRssMb();
  EXPECT_NE(Refusal(FileOf(ChunkRecord("zstd", bomb, 100))).find("decompresses to more"),
            std::string::npos);
  EXPECT_LT(PeakRssMb() - peak_before, 16.0);
  // A cut zstd frame.
  EXPECT_NE(Refusal(FileOf(ChunkRecord("zstd", zstd.substr(0, zstd.size() / 2), records.size())))
                .find("zstd"),
            std::string::npos);
  // Claims more than it holds.
  EXPECT_NE(Refusal(FileOf(ChunkRecord("zstd", zstd, records.size() + 10)))
                .find("decompresses to " + std::to_string(records.size())),
            std::string::npos);
}

}  // namespace
}  // namespace furn
