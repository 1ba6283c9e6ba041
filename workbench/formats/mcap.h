// MCAP, the container `ros2 bag record` writes by default since ROS 2 Iron
// (Jazzy too): written and read here from the public specification
// (https://mcap.dev/spec, major version 0), with Debian's zstd and lz4 for
// compressed chunks. Nothing of ROS is in this file: schemas, channels and
// messages are opaque bytes; ros2_bag.cc gives them their ROS 2 meaning.
//
// The reader is bounded like the other loaders: every length is checked
// against the bytes that remain before anything is read, a chunk is
// decompressed into a buffer that grows only with what the decompressor
// really produced (never to the size its header claims) up to a fixed cap,
// and a damaged file is refused with one line naming the file, the record
// and the byte where it starts.
//
//   McapReader in("run_0.mcap");
//   for (const auto& [id, channel] : in.channels()) ...
//   in.ForEach({id}, [&](const McapMessage& m) { ... });   // log-time order
//
//   McapWriter out("out.mcap", McapWriterOptions{});
//   const uint16_t schema = out.AddSchema("sensor_msgs/msg/Image", "ros2msg", text);
//   const uint16_t channel = out.AddChannel(schema, "/camera/depth", "cdr", {});
//   out.Write(channel, log_time_ns, cdr_bytes);
//   out.Finish();   // summary, chunk indexes, statistics, footer
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace furn {

// The leading and trailing magic bytes of an MCAP file of major version 0.
inline constexpr char kMcapMagic[] = "\x89MCAP0\r\n";
inline constexpr size_t kMcapMagicBytes = 8;

// Bounds of the reader: a message, a chunk's uncompressed records, and the
// messages of one file (each costs a 24-byte locator).
inline constexpr uint64_t kMcapMaxMessageBytes = uint64_t{1} << 28;  // 256 MiB
inline constexpr uint64_t kMcapMaxChunkBytes = uint64_t{1} << 29;    // 512 MiB
inline constexpr uint64_t kMcapMaxMessages = 20'000'000;

enum class McapCompression { kNone, kZstd, kLz4 };
// "", "zstd", "lz4": the chunk record's compression string.
const char* McapCompressionName(McapCompression compression);
// The compression of a name ("none" is ""); InputError for any other.
McapCompression McapCompressionFromName(const std::string& name);

struct McapSchema {
  uint16_t id = 0;
  std::string name, encoding;  // e.g. "sensor_msgs/msg/Image", "ros2msg"
  std::string data;            // the definition text
};

struct McapChannel {
  uint16_t id = 0;
  uint16_t schema_id = 0;  // 0: no schema
  std::string topic, message_encoding;
  std::map<std::string, std::string> metadata;
};

struct McapMessage {
  uint16_t channel_id = 0;
  uint32_t sequence = 0;
  uint64_t log_time = 0, publish_time = 0;  // nanoseconds
  std::vector<uint8_t> data;
};

// A whole MCAP file, read record by record from the start (the summary is
// not trusted for what the data section says, so a file whose writer was
// killed before its summary is still refused only for the missing footer).
class McapReader {
 public:
  // Reads the file's header, schemas, channels and where each message is.
  // Throws InputError naming `path`, the record and its byte offset.
  explicit McapReader(const std::string& path);
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  const std::string& path() const;
  const std::string& profile() const;  // the Header's profile ("ros2")
  const std::map<uint16_t, McapSchema>& schemas() const;
  const std::map<uint16_t, McapChannel>& channels() const;
  // The compression of the first chunk (kNone when unchunked): what a copy
  // of this file is written with.
  McapCompression compression() const;
  // The compression of a file's first chunk (kNone when it has none), found
  // by walking the record prefixes without reading their content or
  // decompressing anything. InputError for a file that is not MCAP.
  static McapCompression FirstChunkCompression(const std::string& path);
  // Messages on the channels.
  int64_t Count(const std::set<uint16_t>& channel_ids) const;
  // The messages on the channels in log-time order (ties in file order),
  // the first `limit` when > 0.
  void ForEach(const std::set<uint16_t>& channel_ids,
               const std::function<void(const McapMessage&)>& each,
               int64_t limit = 0) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct McapWriterOptions {
  std::string profile = "ros2";  // the Header's profile
  std::string library = "furnidet";
  McapCompression compression = McapCompression::kZstd;
  // A chunk is closed once its uncompressed records reach this size (bytes);
  // rosbag2's default.
  size_t chunk_bytes = 768 * 1024;

  bool Check() const;
};

// Writes an MCAP file with chunks, message indexes, a summary (schemas,
// channels, statistics, chunk indexes), summary offsets and every CRC, as
// indexed readers (@mcap/core's McapIndexedReader, rosbag2) expect. Writes
// `path` itself: callers that need an atomic file write a temporary name
// and rename it after Finish().
class McapWriter {
 public:
  McapWriter(const std::string& path, const McapWriterOptions& options);
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  // Ids from 1 in the order added.
  uint16_t AddSchema(const std::string& name, const std::string& encoding, const std::string& data);
  uint16_t AddChannel(uint16_t schema_id,
                      const std::string& topic,
                      const std::string& message_encoding,
                      const std::map<std::string, std::string>& metadata);
  void Write(uint16_t channel_id, uint64_t log_time, const std::vector<uint8_t>& data);
  // Closes the last chunk and writes the data end, summary and footer.
  // Returns the messages written.
  int64_t Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace furn
