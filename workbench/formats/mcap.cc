#include "workbench/formats/mcap.h"

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "core/util/error.h"

namespace furn {
namespace {

// Record opcodes of the specification.
enum Opcode : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

constexpr uint64_t kRecordPrefixBytes = 9;          // opcode + uint64 length
constexpr uint64_t kMessageFixedBytes = 22;         // channel, sequence, two times
constexpr uint64_t kMaxOtherRecordBytes = 1 << 26;  // 64 MiB: a schema, channel, index
constexpr uint64_t kFooterBytes = 20;

const char* OpcodeName(uint8_t opcode) {
  switch (opcode) {
    case kHeader:
      return "Header";
    case kFooter:
      return "Footer";
    case kSchema:
      return "Schema";
    case kChannel:
      return "Channel";
    case kMessage:
      return "Message";
    case kChunk:
      return "Chunk";
    case kMessageIndex:
      return "Message Index";
    case kChunkIndex:
      return "Chunk Index";
    case kStatistics:
      return "Statistics";
    case kSummaryOffset:
      return "Summary Offset";
    case kDataEnd:
      return "Data End";
    default:
      return "record";
  }
}

uint32_t Crc32(const uint8_t* data, size_t size, uint32_t crc = 0) {
  while (size > 0) {  // zlib takes uInt lengths
    const uInt part = static_cast<uInt>(std::min<size_t>(size, 1u << 30));
    crc = static_cast<uint32_t>(crc32(crc, data, part));
    data += part;
    size -= part;
  }
  return crc;
}

// Little-endian fields of one record's content, every read checked against
// the bytes that remain; `where` names the record in errors.
class FieldReader {
 public:
  FieldReader(const uint8_t* data, uint64_t size, std::string where)
      : data_(data), size_(size), where_(std::move(where)) {}

  template <typename T>
  T Read(const char* field) {
    Need(sizeof(T), field);
    T value;
    std::memcpy(&value, data_ + position_, sizeof(T));
    position_ += sizeof(T);
    return value;
  }
  std::string String(const char* field, uint32_t max_bytes = 1 << 16) {
    const uint32_t length = Read<uint32_t>(field);
    Require(length <= max_bytes,
            where_ + ": " + field + " of " + std::to_string(length) + " bytes, more than " +
                std::to_string(max_bytes));
    Need(length, field);
    std::string text(reinterpret_cast<const char*>(data_ + position_), length);
    position_ += length;
    return text;
  }
  // A uint32-prefixed byte string, returned as text (schema data).
  std::string Bytes32(const char* field) { return String(field, kMaxOtherRecordBytes); }
  // A uint32-prefixed map's content, as a reader of its own.
  FieldReader Group(const char* field) {
    const uint32_t length = Read<uint32_t>(field);
    Need(length, field);
    FieldReader group(data_ + position_, length, where_ + " " + field);
    position_ += length;
    return group;
  }
  std::map<std::string, std::string> StringMap(const char* field) {
    FieldReader group = Group(field);
    std::map<std::string, std::string> map;
    while (group.remaining() > 0) {
      std::string key = group.String("a key");
      map[key] = group.String("a value");
    }
    return map;
  }
  // Where the rest of the content starts, and its size.
  const uint8_t* rest() const { return data_ + position_; }
  uint64_t remaining() const { return size_ - position_; }
  void Skip(uint64_t bytes, const char* field) {
    Need(bytes, field);
    position_ += bytes;
  }
  const std::string& where() const { return where_; }

 private:
  void Need(uint64_t bytes, const char* field) const {
    Require(bytes <= size_ - position_,
            where_ + ": " + field + " needs " + std::to_string(bytes) + " bytes, " +
                std::to_string(size_ - position_) + " remain");
  }
  const uint8_t* data_;
  uint64_t size_ = 0, position_ = 0;
  std::string where_;
};

// Little-endian fields appended to a byte buffer.
class FieldWriter {
 public:
  template <typename T>
  FieldWriter& Put(T value) {
    const size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &value, sizeof(T));
    return *this;
  }
  FieldWriter& String(const std::string& text) {
    Put<uint32_t>(static_cast<uint32_t>(text.size()));
    bytes_.insert(bytes_.end(), text.begin(), text.end());
    return *this;
  }
  FieldWriter& Raw(const uint8_t* data, size_t size) {
    bytes_.insert(bytes_.end(), data, data + size);
    return *this;
  }
  FieldWriter& Raw(const std::vector<uint8_t>& data) { return Raw(data.data(), data.size()); }
  // A uint32 byte-length prefix, then what `body` writes.
  template <typename Body>
  FieldWriter& Prefixed(Body body) {
    FieldWriter inner;
    body(inner);
    Put<uint32_t>(static_cast<uint32_t>(inner.bytes_.size()));
    return Raw(inner.bytes_);
  }
  std::vector<uint8_t>& bytes() { return bytes_; }

 private:
  std::vector<uint8_t> bytes_;
};

// A record: opcode, uint64 length, content.
std::vector<uint8_t> Record(uint8_t opcode, const std::vector<uint8_t>& content) {
  FieldWriter record;
  record.Put<uint8_t>(opcode).Put<uint64_t>(content.size()).Raw(content);
  return std::move(record.bytes());
}

// Room for the decompressor's next output once `out` is full: grown with
// what it really wrote, never past `claimed` + 1 bytes, and a chunk that
// decompresses to more than it claims is refused.
void MakeRoom(std::vector<uint8_t>* out,
              size_t produced,
              uint64_t claimed,
              const std::string& where) {
  if (produced < out->size()) return;
  Require(produced <= claimed,
          where + ": decompresses to more than its uncompressed_size " + std::to_string(claimed));
  const uint64_t wanted = std::max<uint64_t>(produced * 2, uint64_t{1} << 20);
  out->resize(static_cast<size_t>(std::min(claimed + 1, wanted)));
}

std::vector<uint8_t> DecompressZstd(const uint8_t* data,
                                    uint64_t size,
                                    uint64_t claimed,
                                    const std::string& where) {
  std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> context(ZSTD_createDCtx(), ZSTD_freeDCtx);
  Require(context != nullptr, where + ": cannot create a zstd decompressor");
  std::vector<uint8_t> out;
  ZSTD_inBuffer in{data, static_cast<size_t>(size), 0};
  size_t produced = 0;
  while (true) {
    MakeRoom(&out, produced, claimed, where);
    ZSTD_outBuffer buffer{out.data(), out.size(), produced};
    const size_t before = in.pos;
    const size_t status = ZSTD_decompressStream(context.get(), &buffer, &in);
    Require(!ZSTD_isError(status), where + ": zstd: " + ZSTD_getErrorName(status));
    const bool progress = buffer.pos != produced || in.pos != before;
    produced = buffer.pos;
    if (status == 0) break;
    Require(progress, where + ": the zstd frame ends early");
  }
  Require(in.pos == in.size, where + ": bytes after the zstd frame");
  out.resize(produced);
  return out;
}

std::vector<uint8_t> DecompressLz4(const uint8_t* data,
                                   uint64_t size,
                                   uint64_t claimed,
                                   const std::string& where) {
  LZ4F_dctx* raw = nullptr;
  Require(!LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION)),
          where + ": cannot create an lz4 decompressor");
  std::unique_ptr<LZ4F_dctx, LZ4F_errorCode_t (*)(LZ4F_dctx*)> context(
      raw, LZ4F_freeDecompressionContext);
  std::vector<uint8_t> out;
  size_t consumed = 0, produced = 0;
  while (true) {
    MakeRoom(&out, produced, claimed, where);
    size_t out_bytes = out.size() - produced, in_bytes = static_cast<size_t>(size) - consumed;
    const size_t hint = LZ4F_decompress(
        context.get(), out.data() + produced, &out_bytes, data + consumed, &in_bytes, nullptr);
    Require(!LZ4F_isError(hint), where + ": lz4: " + LZ4F_getErrorName(hint));
    consumed += in_bytes;
    produced += out_bytes;
    if (hint == 0) break;
    Require(in_bytes > 0 || out_bytes > 0, where + ": the lz4 frame ends early");
  }
  Require(consumed == size, where + ": bytes after the lz4 frame");
  out.resize(produced);
  return out;
}

std::vector<uint8_t> CompressChunk(McapCompression compression, const std::vector<uint8_t>& in) {
  std::vector<uint8_t> out;
  if (compression == McapCompression::kZstd) {
    out.resize(ZSTD_compressBound(in.size()));
    const size_t size = ZSTD_compress(out.data(), out.size(), in.data(), in.size(), 1);
    if (ZSTD_isError(size))
      throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(size));
    out.resize(size);
  } else if (compression == McapCompression::kLz4) {
    out.resize(LZ4F_compressFrameBound(in.size(), nullptr));
    const size_t size = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), nullptr);
    if (LZ4F_isError(size))
      throw std::runtime_error(std::string("lz4: ") + LZ4F_getErrorName(size));
    out.resize(size);
  } else {
    out = in;
  }
  return out;
}

// Where one message is: in a chunk's records (chunk >= 0) or in the file.
struct Locator {
  uint64_t log_time = 0;
  uint64_t offset = 0;  // of the Message record's content
  uint64_t length = 0;  // of that content
  int32_t chunk = -1;
  uint16_t channel = 0;
};

struct ChunkPlace {
  uint64_t records_offset = 0, records_size = 0, uncompressed_size = 0;
  uint32_t crc = 0;
  McapCompression compression = McapCompression::kNone;
  uint64_t record_offset = 0;  // for messages
};

}  // namespace

const char* McapCompressionName(McapCompression compression) {
  switch (compression) {
    case McapCompression::kZstd:
      return "zstd";
    case McapCompression::kLz4:
      return "lz4";
    case McapCompression::kNone:
      break;
  }
  return "";
}

McapCompression McapCompressionFromName(const std::string& name) {
  if (name.empty() || name == "none") return McapCompression::kNone;
  if (name == "zstd") return McapCompression::kZstd;
  if (name == "lz4") return McapCompression::kLz4;
  throw InputError("MCAP compression '" + name.substr(0, 32) + "' is not none, zstd or lz4");
}

// ---------------------------------------------------------------- reading

struct McapReader::Impl {
  std::string path, profile;
  mutable std::ifstream file;
  uint64_t file_size = 0;
  std::map<uint16_t, McapSchema> schemas;
  std::map<uint16_t, McapChannel> channels;
  std::map<uint16_t, int64_t> counts;
  std::vector<ChunkPlace> chunks;
  std::vector<Locator> messages;
  bool has_compression = false;
  McapCompression compression = McapCompression::kNone;
  // The one chunk decompressed last (messages are mostly in chunk order).
  mutable int32_t cached_chunk = -1;
  mutable std::vector<uint8_t> cached_records;

  std::string At(uint64_t offset, uint8_t opcode) const {
    char code[8];
    std::snprintf(code, sizeof code, "0x%02x", opcode);
    return path + ": " + OpcodeName(opcode) + " record (opcode " + code + ") at byte " +
           std::to_string(offset);
  }

  std::vector<uint8_t> ReadBytes(uint64_t offset, uint64_t size) const {
    std::vector<uint8_t> bytes(static_cast<size_t>(size));
    file.clear();
    file.seekg(static_cast<std::streamoff>(offset));
    file.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size));
    Require(file.good() || (size == 0),
            path + ": cannot read " + std::to_string(size) + " bytes at byte " +
                std::to_string(offset));
    return bytes;
  }

  void Open() {
    std::error_code ec;
    Require(std::filesystem::is_regular_file(path, ec), path + ": not a regular file");
    file_size = std::filesystem::file_size(path, ec);
    Require(!ec, path + ": cannot read its size (" + ec.message() + ")");
    file.open(path, std::ios::binary);
    Require(file.is_open(), path + ": cannot open");
    Require(file_size >= 2 * kMcapMagicBytes + kRecordPrefixBytes + kFooterBytes,
            path + ": " + std::to_string(file_size) + " bytes, too short for an MCAP file");
    const std::vector<uint8_t> head = ReadBytes(0, kMcapMagicBytes);
    Require(std::memcmp(head.data(), kMcapMagic, kMcapMagicBytes) == 0,
            path +
                ": no MCAP magic (\\x89MCAP0\\r\\n) at its start: not an MCAP file of major "
                "version 0");
  }

  void AddSchema(McapSchema schema, const std::string& where) {
    Require(schema.id != 0, where + ": schema id 0 is reserved");
    auto [it, added] = schemas.emplace(schema.id, schema);
    Require(added || (it->second.name == schema.name && it->second.data == schema.data),
            where + ": schema " + std::to_string(schema.id) + " redefined differently");
  }

  void AddChannel(McapChannel channel, const std::string& where) {
    Require(channel.schema_id == 0 || schemas.count(channel.schema_id),
            where + ": channel " + std::to_string(channel.id) + " names schema " +
                std::to_string(channel.schema_id) + ", which no record before it defines");
    auto [it, added] = channels.emplace(channel.id, channel);
    Require(
        added || (it->second.topic == channel.topic && it->second.schema_id == channel.schema_id),
        where + ": channel " + std::to_string(channel.id) + " redefined differently");
  }

  void AddMessage(const uint8_t* content,
                  uint64_t size,
                  uint64_t offset,
                  int32_t chunk,
                  const std::string& where) {
    FieldReader in(content, std::min(size, kMessageFixedBytes), where);
    Require(size >= kMessageFixedBytes,
            where + ": a Message record of " + std::to_string(size) +
                " bytes, less than its 22 fixed bytes");
    Require(size - kMessageFixedBytes <= kMcapMaxMessageBytes,
            where + ": a message of " + std::to_string(size - kMessageFixedBytes) +
                " bytes, more than " + std::to_string(kMcapMaxMessageBytes));
    Require(messages.size() < kMcapMaxMessages,
            where + ": more than " + std::to_string(kMcapMaxMessages) + " messages");
    Locator locator;
    locator.channel = in.Read<uint16_t>("channel_id");
    in.Read<uint32_t>("sequence");
    locator.log_time = in.Read<uint64_t>("log_time");
    Require(channels.count(locator.channel),
            where + ": a message on channel " + std::to_string(locator.channel) +
                ", which no record before it defines");
    locator.offset = offset;
    locator.length = size;
    locator.chunk = chunk;
    messages.push_back(locator);
    ++counts[locator.channel];
  }

  // Schema, Channel and Message records of the data section or of a chunk.
  void OnRecord(uint8_t opcode,
                const uint8_t* content,
                uint64_t size,
                uint64_t offset,
                int32_t chunk,
                const std::string& where) {
    FieldReader in(content, size, where);
    if (opcode == kSchema) {
      McapSchema schema;
      schema.id = in.Read<uint16_t>("id");
      schema.name = in.String("name");
      schema.encoding = in.String("encoding");
      schema.data = in.Bytes32("data");
      AddSchema(std::move(schema), where);
    } else if (opcode == kChannel) {
      McapChannel channel;
      channel.id = in.Read<uint16_t>("id");
      channel.schema_id = in.Read<uint16_t>("schema_id");
      channel.topic = in.String("topic");
      channel.message_encoding = in.String("message_encoding");
      channel.metadata = in.StringMap("metadata");
      AddChannel(std::move(channel), where);
    } else if (opcode == kMessage) {
      AddMessage(content, size, offset, chunk, where);
    }
  }

  // The records of a chunk's uncompressed bytes.
  void ScanChunkRecords(const std::vector<uint8_t>& records,
                        int32_t chunk,
                        const std::string& where) {
    uint64_t position = 0;
    while (position < records.size()) {
      const std::string at = where + ", its record at byte " + std::to_string(position);
      Require(records.size() - position >= kRecordPrefixBytes, at + ": truncated record prefix");
      const uint8_t opcode = records[position];
      uint64_t length;
      std::memcpy(&length, records.data() + position + 1, 8);
      Require(length <= records.size() - position - kRecordPrefixBytes,
              at + ": a length of " + std::to_string(length) + " bytes runs past the chunk");
      OnRecord(opcode,
               records.data() + position + kRecordPrefixBytes,
               length,
               position + kRecordPrefixBytes,
               chunk,
               at + " (" + OpcodeName(opcode) + ")");
      position += kRecordPrefixBytes + length;
    }
  }

  std::vector<uint8_t> Decompress(const ChunkPlace& place, const std::string& where) const {
    Require(place.uncompressed_size <= kMcapMaxChunkBytes,
            where + ": uncompressed_size " + std::to_string(place.uncompressed_size) +
                " is more than " + std::to_string(kMcapMaxChunkBytes));
    std::vector<uint8_t> compressed = ReadBytes(place.records_offset, place.records_size);
    std::vector<uint8_t> records;
    switch (place.compression) {
      case McapCompression::kNone:
        Require(place.records_size == place.uncompressed_size,
                where + ": uncompressed chunk of " + std::to_string(place.records_size) +
                    " bytes whose uncompressed_size says " +
                    std::to_string(place.uncompressed_size));
        records = std::move(compressed);
        break;
      case McapCompression::kZstd:
        records =
            DecompressZstd(compressed.data(), compressed.size(), place.uncompressed_size, where);
        break;
      case McapCompression::kLz4:
        records =
            DecompressLz4(compressed.data(), compressed.size(), place.uncompressed_size, where);
        break;
    }
    Require(records.size() == place.uncompressed_size,
            where + ": decompresses to " + std::to_string(records.size()) +
                " bytes, its uncompressed_size says " + std::to_string(place.uncompressed_size));
    Require(place.crc == 0 || Crc32(records.data(), records.size()) == place.crc,
            where + ": uncompressed_crc does not match its records");
    return records;
  }

  void ReadChunk(uint64_t offset, uint64_t length) {
    const std::string where = At(offset, kChunk);
    // The fixed fields and the compression name; the records stay on disk.
    const std::vector<uint8_t> head =
        ReadBytes(offset + kRecordPrefixBytes, std::min<uint64_t>(length, 28 + 4 + 64 + 8));
    FieldReader in(head.data(), head.size(), where);
    ChunkPlace place;
    place.record_offset = offset;
    in.Read<uint64_t>("message_start_time");
    in.Read<uint64_t>("message_end_time");
    place.uncompressed_size = in.Read<uint64_t>("uncompressed_size");
    place.crc = in.Read<uint32_t>("uncompressed_crc");
    const std::string compression_name = in.String("compression", 64);
    try {
      place.compression = McapCompressionFromName(compression_name);
    } catch (const InputError& e) {
      throw InputError(where + ": " + e.what());
    }
    place.records_size = in.Read<uint64_t>("records length");
    const uint64_t fixed = head.size() - in.remaining();
    Require(place.records_size <= length - fixed,
            where + ": records of " + std::to_string(place.records_size) +
                " bytes run past the record");
    place.records_offset = offset + kRecordPrefixBytes + fixed;
    if (!has_compression) {
      has_compression = true;
      compression = place.compression;
    }
    chunks.push_back(place);
    ScanChunkRecords(Decompress(place, where), static_cast<int32_t>(chunks.size() - 1), where);
  }

  // Walks the records from the header to the footer.
  void Scan() {
    uint64_t position = kMcapMagicBytes;
    bool data_section = true, first = true;
    while (true) {
      Require(file_size - position >= kRecordPrefixBytes,
              path + ": ends at byte " + std::to_string(file_size) +
                  " without a Footer (a recording that did not finish; rosbag2's "
                  "'ros2 bag reindex' or 'mcap recover' repairs it)");
      const std::vector<uint8_t> prefix = ReadBytes(position, kRecordPrefixBytes);
      const uint8_t opcode = prefix[0];
      uint64_t length;
      std::memcpy(&length, prefix.data() + 1, 8);
      const std::string where = At(position, opcode);
      Require(length <= file_size - position - kRecordPrefixBytes,
              where + ": a length of " + std::to_string(length) +
                  " bytes runs past the file's end at byte " + std::to_string(file_size) +
                  ": the file is cut short or damaged (a recording that did not finish is "
                  "repaired by 'ros2 bag reindex' or 'mcap recover')");
      Require(!first || opcode == kHeader, where + ": the first record must be a Header");
      if (opcode == kFooter) {
        Require(position + kRecordPrefixBytes + length + kMcapMagicBytes == file_size,
                where + ": the Footer must be followed by the closing magic and nothing else");
        const std::vector<uint8_t> tail = ReadBytes(file_size - kMcapMagicBytes, kMcapMagicBytes);
        Require(std::memcmp(tail.data(), kMcapMagic, kMcapMagicBytes) == 0,
                path + ": no closing MCAP magic");
        return;
      }
      if (opcode == kChunk && data_section) {
        ReadChunk(position, length);
      } else if (opcode == kHeader || (data_section && (opcode == kSchema || opcode == kChannel ||
                                                        opcode == kMessage))) {
        Require(first || opcode != kHeader, where + ": a second Header");
        const uint64_t cap =
            opcode == kMessage ? kMcapMaxMessageBytes + kMessageFixedBytes : kMaxOtherRecordBytes;
        Require(length <= cap,
                where + ": " + std::to_string(length) + " bytes, more than " + std::to_string(cap));
        const uint64_t read = opcode == kMessage ? kMessageFixedBytes : length;
        const std::vector<uint8_t> content =
            ReadBytes(position + kRecordPrefixBytes, std::min(read, length));
        if (opcode == kHeader) {
          FieldReader in(content.data(), content.size(), where);
          profile = in.String("profile");
          in.String("library");
        } else if (opcode == kMessage) {
          Require(length >= kMessageFixedBytes,
                  where + ": shorter than a message's 22 fixed bytes");
          AddMessage(content.data(), length, position + kRecordPrefixBytes, -1, where);
        } else {
          OnRecord(opcode, content.data(), length, position + kRecordPrefixBytes, -1, where);
        }
      } else if (opcode == kDataEnd) {
        data_section = false;  // the summary repeats what the data section said
      }
      first = false;
      position += kRecordPrefixBytes + length;
    }
  }

  const std::vector<uint8_t>& ChunkRecords(int32_t chunk) const {
    if (cached_chunk != chunk) {
      cached_records.clear();
      cached_chunk = -1;
      cached_records = Decompress(chunks[static_cast<size_t>(chunk)],
                                  At(chunks[static_cast<size_t>(chunk)].record_offset, kChunk));
      cached_chunk = chunk;
    }
    return cached_records;
  }

  McapMessage Load(const Locator& locator) const {
    std::vector<uint8_t> content;
    const uint8_t* bytes = nullptr;
    if (locator.chunk < 0) {
      content = ReadBytes(locator.offset, locator.length);
      bytes = content.data();
    } else {
      bytes = ChunkRecords(locator.chunk).data() + locator.offset;
    }
    FieldReader in(bytes, locator.length, path + ": a message");
    McapMessage message;
    message.channel_id = in.Read<uint16_t>("channel_id");
    message.sequence = in.Read<uint32_t>("sequence");
    message.log_time = in.Read<uint64_t>("log_time");
    message.publish_time = in.Read<uint64_t>("publish_time");
    message.data.assign(in.rest(), in.rest() + in.remaining());
    return message;
  }
};

McapReader::McapReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->Open();
  impl_->Scan();
  std::stable_sort(impl_->messages.begin(),
                   impl_->messages.end(),
                   [](const Locator& a, const Locator& b) { return a.log_time < b.log_time; });
}

McapReader::~McapReader() = default;

const std::string& McapReader::path() const { return impl_->path; }
const std::string& McapReader::profile() const { return impl_->profile; }
const std::map<uint16_t, McapSchema>& McapReader::schemas() const { return impl_->schemas; }
const std::map<uint16_t, McapChannel>& McapReader::channels() const { return impl_->channels; }
McapCompression McapReader::compression() const { return impl_->compression; }

int64_t McapReader::Count(const std::set<uint16_t>& channel_ids) const {
  int64_t count = 0;
  for (uint16_t id : channel_ids) {
    const auto found = impl_->counts.find(id);
    if (found != impl_->counts.end()) count += found->second;
  }
  return count;
}

void McapReader::ForEach(const std::set<uint16_t>& channel_ids,
                         const std::function<void(const McapMessage&)>& each,
                         int64_t limit) const {
  int64_t done = 0;
  for (const Locator& locator : impl_->messages) {
    if (!channel_ids.count(locator.channel)) continue;
    if (limit > 0 && done >= limit) break;
    each(impl_->Load(locator));
    ++done;
  }
}

McapCompression McapReader::FirstChunkCompression(const std::string& path) {
  McapReader::Impl probe;  // opened, not scanned
  probe.path = path;
  probe.Open();
  uint64_t position = kMcapMagicBytes;
  while (probe.file_size - position >= kRecordPrefixBytes) {
    const std::vector<uint8_t> prefix = probe.ReadBytes(position, kRecordPrefixBytes);
    uint64_t length;
    std::memcpy(&length, prefix.data() + 1, 8);
    if (length > probe.file_size - position - kRecordPrefixBytes) break;
    if (prefix[0] == kChunk) {
      const std::vector<uint8_t> head =
          probe.ReadBytes(position + kRecordPrefixBytes, std::min<uint64_t>(length, 28 + 4 + 64));
      const std::string where = probe.At(position, kChunk);
      FieldReader in(head.data(), head.size(), where);
      in.Skip(28, "the chunk's times, size and crc");
      try {
        return McapCompressionFromName(in.String("compression", 64));
      } catch (const InputError& e) {
        throw InputError(where + ": " + e.what());
      }
    }
    if (prefix[0] == kDataEnd || prefix[0] == kFooter) break;
    position += kRecordPrefixBytes + length;
  }
  return McapCompression::kNone;
}

// ---------------------------------------------------------------- writing

bool McapWriterOptions::Check() const {
  return !profile.empty() && chunk_bytes >= 1024 && chunk_bytes <= kMcapMaxChunkBytes / 2;
}

namespace {

struct ChunkIndexEntry {
  uint64_t start_time = 0, end_time = 0, offset = 0, length = 0;
  std::map<uint16_t, uint64_t> index_offsets;
  uint64_t index_length = 0, compressed_size = 0, uncompressed_size = 0;
};

}  // namespace

struct McapWriter::Impl {
  std::string path;
  McapWriterOptions options;
  std::ofstream file;
  uint64_t position = 0;
  uint32_t data_crc = 0;
  bool finished = false;

  std::vector<McapSchema> schemas;
  std::vector<McapChannel> channels;
  std::map<uint16_t, uint64_t> channel_counts;
  std::map<uint16_t, uint32_t> sequences;
  std::vector<ChunkIndexEntry> chunk_indexes;
  uint64_t messages = 0, first_time = std::numeric_limits<uint64_t>::max(), last_time = 0;

  // The open chunk.
  std::vector<uint8_t> chunk;
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> chunk_index;
  uint64_t chunk_start = std::numeric_limits<uint64_t>::max(), chunk_end = 0;

  void Emit(const std::vector<uint8_t>& bytes, uint32_t* crc = nullptr) {
    file.write(reinterpret_cast<const char*>(bytes.data()),
               static_cast<std::streamsize>(bytes.size()));
    Require(file.good(), path + ": cannot write (disk full?)");
    if (crc) *crc = Crc32(bytes.data(), bytes.size(), *crc);
    position += bytes.size();
  }
  void EmitData(const std::vector<uint8_t>& bytes) { Emit(bytes, &data_crc); }

  void AppendToChunk(const std::vector<uint8_t>& record) {
    chunk.insert(chunk.end(), record.begin(), record.end());
  }

  void FlushChunk() {
    if (chunk.empty()) return;
    ChunkIndexEntry entry;
    entry.start_time = chunk_index.empty() ? 0 : chunk_start;
    entry.end_time = chunk_index.empty() ? 0 : chunk_end;
    entry.offset = position;
    entry.uncompressed_size = chunk.size();
    const std::vector<uint8_t> compressed = CompressChunk(options.compression, chunk);
    entry.compressed_size = compressed.size();
    FieldWriter content;
    content.Put<uint64_t>(entry.start_time)
        .Put<uint64_t>(entry.end_time)
        .Put<uint64_t>(chunk.size())
        .Put<uint32_t>(Crc32(chunk.data(), chunk.size()))
        .String(McapCompressionName(options.compression))
        .Put<uint64_t>(compressed.size())
        .Raw(compressed);
    EmitData(Record(kChunk, content.bytes()));
    entry.length = position - entry.offset;
    const uint64_t index_start = position;
    for (const auto& [channel, records] : chunk_index) {
      FieldWriter index;
      index.Put<uint16_t>(channel).Prefixed([&](FieldWriter& array) {
        for (const auto& [time, offset] : records) array.Put<uint64_t>(time).Put<uint64_t>(offset);
      });
      entry.index_offsets[channel] = position;
      EmitData(Record(kMessageIndex, index.bytes()));
    }
    entry.index_length = position - index_start;
    chunk_indexes.push_back(entry);
    chunk.clear();
    chunk_index.clear();
    chunk_start = std::numeric_limits<uint64_t>::max();
    chunk_end = 0;
  }

  static std::vector<uint8_t> SchemaRecord(const McapSchema& schema) {
    FieldWriter content;
    content.Put<uint16_t>(schema.id)
        .String(schema.name)
        .String(schema.encoding)
        .String(schema.data);
    return Record(kSchema, content.bytes());
  }
  static std::vector<uint8_t> ChannelRecord(const McapChannel& channel) {
    FieldWriter content;
    content.Put<uint16_t>(channel.id)
        .Put<uint16_t>(channel.schema_id)
        .String(channel.topic)
        .String(channel.message_encoding)
        .Prefixed([&](FieldWriter& map) {
          for (const auto& [key, value] : channel.metadata) map.String(key).String(value);
        });
    return Record(kChannel, content.bytes());
  }
  std::vector<uint8_t> StatisticsRecord() const {
    FieldWriter content;
    content.Put<uint64_t>(messages)
        .Put<uint16_t>(static_cast<uint16_t>(schemas.size()))
        .Put<uint32_t>(static_cast<uint32_t>(channels.size()))
        .Put<uint32_t>(0)  // attachments
        .Put<uint32_t>(0)  // metadata
        .Put<uint32_t>(static_cast<uint32_t>(chunk_indexes.size()))
        .Put<uint64_t>(messages > 0 ? first_time : 0)
        .Put<uint64_t>(messages > 0 ? last_time : 0)
        .Prefixed([&](FieldWriter& map) {
          for (const auto& [channel, count] : channel_counts)
            map.Put<uint16_t>(channel).Put<uint64_t>(count);
        });
    return Record(kStatistics, content.bytes());
  }
  std::vector<uint8_t> ChunkIndexRecord(const ChunkIndexEntry& entry) const {
    FieldWriter content;
    content.Put<uint64_t>(entry.start_time)
        .Put<uint64_t>(entry.end_time)
        .Put<uint64_t>(entry.offset)
        .Put<uint64_t>(entry.length)
        .Prefixed([&](FieldWriter& map) {
          for (const auto& [channel, offset] : entry.index_offsets)
            map.Put<uint16_t>(channel).Put<uint64_t>(offset);
        })
        .Put<uint64_t>(entry.index_length)
        .String(McapCompressionName(options.compression))
        .Put<uint64_t>(entry.compressed_size)
        .Put<uint64_t>(entry.uncompressed_size);
    return Record(kChunkIndex, content.bytes());
  }

  // The summary: groups of schemas, channels, statistics and chunk indexes,
  // then one Summary Offset per group, then the footer and the magic.
  void WriteSummary() {
    const uint64_t summary_start = position;
    uint32_t summary_crc = 0;
    std::vector<std::tuple<uint8_t, uint64_t, uint64_t>> groups;
    auto group = [&](uint8_t opcode, const std::vector<std::vector<uint8_t>>& records) {
      if (records.empty()) return;
      const uint64_t start = position;
      for (const std::vector<uint8_t>& record : records) Emit(record, &summary_crc);
      groups.emplace_back(opcode, start, position - start);
    };
    std::vector<std::vector<uint8_t>> records;
    for (const McapSchema& schema : schemas) records.push_back(SchemaRecord(schema));
    group(kSchema, records);
    records.clear();
    for (const McapChannel& channel : channels) records.push_back(ChannelRecord(channel));
    group(kChannel, records);
    group(kStatistics, {StatisticsRecord()});
    records.clear();
    for (const ChunkIndexEntry& entry : chunk_indexes) records.push_back(ChunkIndexRecord(entry));
    group(kChunkIndex, records);
    const uint64_t offsets_start = position;
    for (const auto& [opcode, start, length] : groups) {
      FieldWriter content;
      content.Put<uint8_t>(opcode).Put<uint64_t>(start).Put<uint64_t>(length);
      Emit(Record(kSummaryOffset, content.bytes()), &summary_crc);
    }
    FieldWriter footer;
    footer.Put<uint8_t>(kFooter)
        .Put<uint64_t>(kFooterBytes)
        .Put<uint64_t>(summary_start)
        .Put<uint64_t>(offsets_start);
    summary_crc = Crc32(footer.bytes().data(), footer.bytes().size(), summary_crc);
    footer.Put<uint32_t>(summary_crc);
    Emit(footer.bytes());
    Emit(std::vector<uint8_t>(kMcapMagic, kMcapMagic + kMcapMagicBytes));
  }
};

McapWriter::McapWriter(const std::string& path, const McapWriterOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Require(options.Check(),
          path + ": MCAP writer options: profile must not be empty and chunk_bytes (" +
              std::to_string(options.chunk_bytes) + ") within 1 KiB .. 256 MiB");
  impl_->path = path;
  impl_->options = options;
  impl_->file.open(path, std::ios::binary | std::ios::trunc);
  Require(impl_->file.is_open(), path + ": cannot create");
  impl_->EmitData(std::vector<uint8_t>(kMcapMagic, kMcapMagic + kMcapMagicBytes));
  FieldWriter header;
  header.String(options.profile).String(options.library);
  impl_->EmitData(Record(kHeader, header.bytes()));
}

McapWriter::~McapWriter() = default;

uint16_t McapWriter::AddSchema(const std::string& name,
                               const std::string& encoding,
                               const std::string& data) {
  Require(impl_->schemas.size() < 65535, impl_->path + ": more than 65535 schemas");
  McapSchema schema{static_cast<uint16_t>(impl_->schemas.size() + 1), name, encoding, data};
  impl_->AppendToChunk(Impl::SchemaRecord(schema));
  impl_->schemas.push_back(std::move(schema));
  return impl_->schemas.back().id;
}

uint16_t McapWriter::AddChannel(uint16_t schema_id,
                                const std::string& topic,
                                const std::string& message_encoding,
                                const std::map<std::string, std::string>& metadata) {
  Require(schema_id <= impl_->schemas.size(),
          impl_->path + ": channel " + topic + " names schema " + std::to_string(schema_id) +
              ", which was not added");
  Require(impl_->channels.size() < 65535, impl_->path + ": more than 65535 channels");
  McapChannel channel{static_cast<uint16_t>(impl_->channels.size() + 1),
                      schema_id,
                      topic,
                      message_encoding,
                      metadata};
  impl_->AppendToChunk(Impl::ChannelRecord(channel));
  impl_->channels.push_back(std::move(channel));
  return impl_->channels.back().id;
}

void McapWriter::Write(uint16_t channel_id, uint64_t log_time, const std::vector<uint8_t>& data) {
  Require(channel_id >= 1 && channel_id <= impl_->channels.size(),
          impl_->path + ": channel " + std::to_string(channel_id) + " was not added");
  Require(data.size() <= kMcapMaxMessageBytes,
          impl_->path + ": a message of " + std::to_string(data.size()) + " bytes, more than " +
              std::to_string(kMcapMaxMessageBytes));
  FieldWriter content;
  content.Put<uint16_t>(channel_id)
      .Put<uint32_t>(impl_->sequences[channel_id]++)
      .Put<uint64_t>(log_time)
      .Put<uint64_t>(log_time)  // publish time: the same, as rosbag2 writes when it has none
      .Raw(data);
  impl_->chunk_index[channel_id].emplace_back(log_time, impl_->chunk.size());
  impl_->AppendToChunk(Record(kMessage, content.bytes()));
  impl_->chunk_start = std::min(impl_->chunk_start, log_time);
  impl_->chunk_end = std::max(impl_->chunk_end, log_time);
  ++impl_->channel_counts[channel_id];
  ++impl_->messages;
  impl_->first_time = std::min(impl_->first_time, log_time);
  impl_->last_time = std::max(impl_->last_time, log_time);
  if (impl_->chunk.size() >= impl_->options.chunk_bytes) impl_->FlushChunk();
}

int64_t McapWriter::Finish() {
  Require(!impl_->finished, impl_->path + ": finished twice");
  impl_->FlushChunk();
  FieldWriter data_end;
  data_end.Put<uint32_t>(impl_->data_crc);
  impl_->Emit(Record(kDataEnd, data_end.bytes()));
  impl_->WriteSummary();
  impl_->file.flush();
  Require(impl_->file.good(), impl_->path + ": cannot write (disk full?)");
  impl_->file.close();
  impl_->finished = true;
  return static_cast<int64_t>(impl_->messages);
}

}  // namespace furn
