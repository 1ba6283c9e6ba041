#include "workbench/formats/bag_check.h"

#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <set>

#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr size_t kMagicBytes = sizeof(kMagic) - 1;
constexpr uint32_t kMaxHeaderBytes = 1u << 20;  // record headers are a few hundred bytes
// A chunk's uncompressed size: the bag library allocates it before reading
// (rosbag's chunks are 768 KiB by default; 256 MiB is far beyond any real one).
constexpr uint64_t kMaxChunkBytes = uint64_t{1} << 28;

// Record op codes of the bag format 2.0: message data, bag header, index
// data, chunk, chunk info, connection.
constexpr uint8_t kMessageData = 0x02, kBagHeader = 0x03, kIndexData = 0x04, kChunk = 0x05,
                  kChunkInfo = 0x06, kConnection = 0x07;

uint32_t U32(const char* at) {
  uint32_t value;
  std::memcpy(&value, at, 4);
  return value;
}

uint64_t U64(const char* at) {
  uint64_t value;
  std::memcpy(&value, at, 8);
  return value;
}

// A record header's fields, name -> value bytes, each within the header.
std::map<std::string, std::string> HeaderFields(const std::string& header,
                                                const std::string& where) {
  std::map<std::string, std::string> fields;
  size_t at = 0;
  while (at < header.size()) {
    Require(header.size() - at >= 4, where + ": a header field's length is cut off");
    const uint32_t length = U32(header.data() + at);
    at += 4;
    Require(length <= header.size() - at,
            where + ": a header field of " + std::to_string(length) +
                " bytes runs past its header (" + std::to_string(header.size() - at) + " left)");
    const std::string field = header.substr(at, length);
    at += length;
    const size_t equals = field.find('=');
    Require(equals != std::string::npos, where + ": a header field has no '='");
    fields[field.substr(0, equals)] = field.substr(equals + 1);
  }
  return fields;
}

// A field of a fixed size, as the bag format defines it.
const std::string& Field(const std::map<std::string, std::string>& fields,
                         const char* name,
                         size_t bytes,
                         const std::string& where) {
  const auto it = fields.find(name);
  Require(it != fields.end(), where + ": its header lacks the field '" + name + "'");
  Require(bytes == 0 || it->second.size() == bytes,
          where + ": header field '" + name + "' has " + std::to_string(it->second.size()) +
              " bytes, not " + std::to_string(bytes));
  return it->second;
}

// Walks records [begin, end) of `bytes` or of the file, checking them.
class BagWalker {
 public:
  BagWalker(const std::string& path, uint64_t file_size) : path_(path), file_size_(file_size) {}
  // The first chunk's compression; "none" when the bag has no chunk.
  std::string first_compression() const {
    return first_compression_.empty() ? "none" : first_compression_;
  }

  // One record at `at` (within [at, end)): returns the next record's offset.
  uint64_t Record(std::istream& in, uint64_t at, uint64_t end, bool in_chunk) {
    const std::string where = path_ + ": not a readable ROS 1 bag: record at byte " +
                              std::to_string(at) + (in_chunk ? " of a chunk" : "");
    Require(end - at >= 8, where + ": cut off (its lengths need 8 bytes)");
    if (in_chunk) {
      chunk_record_starts_.insert(at - chunk_data_at_);
    } else {
      record_starts_.insert(at);
    }
    char length[4];
    Read(in, length, 4, where);
    const uint32_t header_bytes = U32(length);
    Require(header_bytes <= kMaxHeaderBytes && header_bytes <= end - at - 8,
            where + ": a header of " + std::to_string(header_bytes) + " bytes runs past the " +
                (in_chunk ? "chunk" : "file"));
    std::string header(header_bytes, '\0');
    Read(in, header.data(), header_bytes, where);
    Read(in, length, 4, where);
    const uint64_t data_bytes = U32(length);
    const uint64_t data_at = at + 8 + header_bytes;
    Require(data_bytes <= end - data_at,
            where + ": data of " + std::to_string(data_bytes) + " bytes runs past the " +
                (in_chunk ? "chunk" : "file") + " (" + std::to_string(end - data_at) + " left)");
    const std::map<std::string, std::string> fields = HeaderFields(header, where);
    const uint8_t op = static_cast<uint8_t>(Field(fields, "op", 1, where)[0]);
    CheckOp(op, fields, in, at, data_at, data_bytes, in_chunk, where);
    return data_at + data_bytes;
  }

  void CheckChunkInfos() const {
    for (const auto& [info_at, chunk_at] : chunk_infos_) {
      Require(chunks_.count(chunk_at) > 0,
              path_ + ": the chunk info at byte " + std::to_string(info_at) +
                  " names no chunk (byte " + std::to_string(chunk_at) + ")");
    }
    // The bag library starts reading records there: anywhere but a record's
    // start, it takes other bytes for lengths (a 6 KB bag asked for 2.3 GB).
    Require(!index_pos_ || *index_pos_ == file_size_ || record_starts_.count(*index_pos_) > 0,
            path_ + ": the bag header's index position (byte " +
                std::to_string(index_pos_.value_or(0)) + ") is not the start of a record");
  }

 private:
  void Read(std::istream& in, char* out, size_t bytes, const std::string& where) {
    in.read(out, static_cast<std::streamsize>(bytes));
    Require(in.gcount() == static_cast<std::streamsize>(bytes), where + ": cannot read (cut off)");
  }

  void CheckOp(uint8_t op,
               const std::map<std::string, std::string>& fields,
               std::istream& in,
               uint64_t record_at,
               uint64_t data_at,
               uint64_t data_bytes,
               bool in_chunk,
               const std::string& where) {
    switch (op) {
      case kBagHeader:
        index_pos_ = U64(Field(fields, "index_pos", 8, where).data());
        break;
      case kChunk:
        Require(!in_chunk, where + ": a chunk inside a chunk");
        Chunk(fields, in, record_at, data_at, data_bytes, where);
        return;
      case kIndexData:
        IndexData(fields, in, data_bytes, where);
        return;
      case kChunkInfo:
        chunk_infos_[data_at] = U64(Field(fields, "chunk_pos", 8, where).data());
        Require(data_bytes == 8ull * U32(Field(fields, "count", 4, where).data()),
                where + ": chunk info data is not 8 bytes per connection count");
        break;
      case kConnection:
        Field(fields, "conn", 4, where);
        Field(fields, "topic", 0, where);
        ConnectionHeader(in, data_bytes, where);
        return;
      case kMessageData:
        Field(fields, "conn", 4, where);
        Field(fields, "time", 8, where);
        break;
      default:
        throw InputError(where + ": unknown record op " + std::to_string(op));
    }
    in.seekg(static_cast<std::streamoff>(data_bytes), std::ios::cur);
  }

  void Chunk(const std::map<std::string, std::string>& fields,
             std::istream& in,
             uint64_t record_at,
             uint64_t data_at,
             uint64_t data_bytes,
             const std::string& where) {
    const std::string& compression = Field(fields, "compression", 0, where);
    Require(
        compression == "none" || compression == "lz4" || compression == "bz2",
        where + ": chunk compression '" + compression.substr(0, 20) + "' is not none, lz4 or bz2");
    const uint64_t size = U32(Field(fields, "size", 4, where).data());
    Require(size <= kMaxChunkBytes, where + ": a chunk of " + std::to_string(size) + " bytes");
    Require(compression != "none" || size == data_bytes,
            where + ": an uncompressed chunk's size " + std::to_string(size) +
                " is not its data's " + std::to_string(data_bytes));
    chunks_[record_at] = size;
    last_chunk_size_ = size;
    if (first_compression_.empty()) first_compression_ = compression;
    chunk_record_starts_.clear();
    chunk_compressed_ = compression != "none";
    if (compression == "none") {  // its records, within it
      chunk_data_at_ = data_at;
      const uint64_t end = data_at + data_bytes;
      for (uint64_t at = data_at; at < end;) at = Record(in, at, end, /*in_chunk=*/true);
    } else {
      in.seekg(static_cast<std::streamoff>(data_bytes), std::ios::cur);
    }
  }

  // Entries (time, offset) into the chunk before it.
  void IndexData(const std::map<std::string, std::string>& fields,
                 std::istream& in,
                 uint64_t data_bytes,
                 const std::string& where) {
    Require(last_chunk_size_.has_value(), where + ": index data before any chunk");
    const uint32_t count = U32(Field(fields, "count", 4, where).data());
    Require(data_bytes == 12ull * count,
            where + ": index data of " + std::to_string(data_bytes) + " bytes for " +
                std::to_string(count) + " entries (12 bytes each)");
    std::string entries(data_bytes, '\0');
    Read(in, entries.data(), data_bytes, where);
    for (uint32_t k = 0; k < count; ++k) {
      const uint32_t offset = U32(entries.data() + 12 * k + 8);
      Require(static_cast<uint64_t>(offset) + 8 <= *last_chunk_size_,
              where + ": index entry " + std::to_string(k) + " points at byte " +
                  std::to_string(offset) + ", past its chunk of " +
                  std::to_string(*last_chunk_size_) + " bytes");
      // Within an uncompressed chunk, at one of its records (the records of
      // a compressed chunk are not walked; their offsets only bounded).
      Require(chunk_compressed_ || chunk_record_starts_.count(offset) > 0,
              where + ": index entry " + std::to_string(k) + " points at byte " +
                  std::to_string(offset) + " of its chunk, which starts no record");
    }
  }

  void ConnectionHeader(std::istream& in, uint64_t data_bytes, const std::string& where) {
    Require(data_bytes <= kMaxHeaderBytes,
            where + ": a connection header of " + std::to_string(data_bytes) + " bytes");
    std::string header(data_bytes, '\0');
    Read(in, header.data(), data_bytes, where);
    HeaderFields(header, where + " (connection header)");
  }

  const std::string path_;
  const uint64_t file_size_;
  std::map<uint64_t, uint64_t> chunks_;       // record offset -> uncompressed size
  std::map<uint64_t, uint64_t> chunk_infos_;  // info's data offset -> chunk offset
  std::optional<uint64_t> last_chunk_size_;
  std::optional<uint64_t> index_pos_;
  std::set<uint64_t> record_starts_;        // of the records outside chunks
  std::set<uint64_t> chunk_record_starts_;  // of the last chunk's records, from its data
  uint64_t chunk_data_at_ = 0;              // where the last chunk's data starts
  bool chunk_compressed_ = false;
  std::string first_compression_;  // of the first chunk
};

// A bounded reader of ROS 1 serialized fields (little endian; strings and
// variable arrays as a u32 count, then the elements).
class FieldReader {
 public:
  FieldReader(const std::vector<uint8_t>& bytes, const std::string& where)
      : bytes_(bytes), where_(where) {}

  void Skip(size_t count, const char* what) {
    Require(count <= bytes_.size() - at_,
            where_ + ": " + what + " needs " + std::to_string(count) + " bytes, " +
                std::to_string(bytes_.size() - at_) + " left");
    at_ += count;
  }
  uint32_t U32(const char* what) {
    const size_t at = at_;
    Skip(4, what);
    uint32_t value;
    std::memcpy(&value, bytes_.data() + at, 4);
    return value;
  }
  // A variable array of `count` elements of at least `element_bytes` each:
  // the count must fit in the bytes left before anything is read.
  uint32_t Count(size_t element_bytes, const char* what) {
    const uint32_t count = U32(what);
    Require(static_cast<uint64_t>(count) * element_bytes <= bytes_.size() - at_,
            where_ + ": " + what + " claims " + std::to_string(count) + " elements of " +
                std::to_string(element_bytes) + "+ bytes, " + std::to_string(bytes_.size() - at_) +
                " bytes left");
    return count;
  }
  void String(const char* what) { Skip(Count(1, what), what); }
  void Header() {
    Skip(12, "header seq and stamp");
    String("header frame_id");
  }
  void End() const {
    Require(at_ == bytes_.size(),
            where_ + ": " + std::to_string(bytes_.size() - at_) + " bytes after the message");
  }

 private:
  const std::vector<uint8_t>& bytes_;
  const std::string where_;
  size_t at_ = 0;
};

void ImageFields(FieldReader* r) {
  r->Header();
  r->Skip(8, "height and width");
  r->String("encoding");
  r->Skip(5, "is_bigendian and step");
  r->String("data");
}

void PointCloud2Fields(FieldReader* r) {
  r->Header();
  r->Skip(8, "height and width");
  const uint32_t fields = r->Count(13, "fields");  // name length, offset, datatype, count
  for (uint32_t k = 0; k < fields; ++k) {
    r->String("field name");
    r->Skip(9, "field offset, datatype and count");
  }
  r->Skip(9, "is_bigendian, point_step and row_step");
  r->String("data");
  r->Skip(1, "is_dense");
}

void CameraInfoFields(FieldReader* r) {
  r->Header();
  r->Skip(8, "height and width");
  r->String("distortion_model");
  r->Skip(8 * static_cast<size_t>(r->Count(8, "D")), "D");
  r->Skip(8 * (9 + 9 + 12), "K, R and P");
  r->Skip(8 + 17, "binning and roi");
}

void TfMessageFields(FieldReader* r) {
  const uint32_t transforms = r->Count(12 + 4 + 4 + 56, "transforms");
  for (uint32_t k = 0; k < transforms; ++k) {
    r->Header();
    r->String("child_frame_id");
    r->Skip(56, "translation and rotation");
  }
}

}  // namespace

void CheckMessageFields(const std::string& type,
                        const std::vector<uint8_t>& bytes,
                        const std::string& where) {
  FieldReader reader(bytes, where + " (" + type + ")");
  if (type == "sensor_msgs/Image") {
    ImageFields(&reader);
  } else if (type == "sensor_msgs/PointCloud2") {
    PointCloud2Fields(&reader);
  } else if (type == "sensor_msgs/CameraInfo") {
    CameraInfoFields(&reader);
  } else if (type == "tf2_msgs/TFMessage") {
    TfMessageFields(&reader);
  } else {
    return;
  }
  reader.End();
}

std::string CheckBagFile(const std::string& path) {
  RequireRegularFile(path);
  std::ifstream in(path, std::ios::binary);
  Require(in.good(), path + ": cannot open");
  in.seekg(0, std::ios::end);
  const uint64_t size = static_cast<uint64_t>(in.tellg());
  in.seekg(0);
  char magic[kMagicBytes] = {};
  in.read(magic, kMagicBytes);
  Require(in.gcount() == static_cast<std::streamsize>(kMagicBytes) &&
              std::memcmp(magic, kMagic, kMagicBytes) == 0,
          path + ": not a ROS 1 bag of format 2.0 (no '#ROSBAG V2.0' line)");
  BagWalker walker(path, size);
  for (uint64_t at = kMagicBytes; at < size;) {
    in.seekg(static_cast<std::streamoff>(at));
    at = walker.Record(in, at, size, /*in_chunk=*/false);
  }
  walker.CheckChunkInfos();
  return walker.first_compression();
}

}  // namespace furn
