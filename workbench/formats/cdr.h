// CDR, the byte layout of ROS 2 messages in bags (OMG DDS-XTypes plain CDR,
// little-endian): a 4-byte encapsulation header (0x00 0x01 0x00 0x00), then
// each primitive aligned to its own size (at most 8) counted from the end of
// that header; strings as a uint32 length with their terminating NUL;
// sequences as a uint32 count and the elements; fixed arrays bare.
//
// The reader is bounded: every length is checked against the bytes that
// remain before anything is allocated or read, so a damaged or hostile
// message costs at most its own size.
//
//   CdrReader in(blob.data(), blob.size(), "bag.db3 /camera/depth at 1.5 s");
//   const int32_t sec = in.Read<int32_t>();
//   const std::string frame = in.String("frame_id");
//
//   CdrWriter out;
//   out.Write<int32_t>(sec);
//   out.String("camera");
//   std::vector<uint8_t> blob = out.Take();
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

namespace furn {

class CdrReader {
 public:
  // `where` names the message in errors. Throws InputError when the header
  // is not little-endian plain CDR.
  CdrReader(const uint8_t* data, size_t size, std::string where);

  template <typename T>
  T Read(const char* field = "a value") {
    static_assert(std::is_arithmetic_v<T>);
    Align(sizeof(T));
    Need(sizeof(T), field);
    T value;
    std::memcpy(&value, data_ + position_, sizeof(T));
    position_ += sizeof(T);
    return value;
  }
  bool ReadBool(const char* field) { return Read<uint8_t>(field) != 0; }
  // A string; refused when its length runs past the message, lacks its NUL
  // or exceeds `max_bytes`.
  std::string String(const char* field, uint32_t max_bytes = 4096);
  // A sequence's element count, refused when `count` x `min_element_bytes`
  // exceeds what remains.
  uint32_t SequenceLength(const char* field, size_t min_element_bytes);
  // A uint8[] sequence: pointer into the message and its size (no copy).
  std::pair<const uint8_t*, size_t> Bytes(const char* field);

  size_t remaining() const { return size_ - position_; }
  const std::string& where() const { return where_; }

 private:
  void Align(size_t alignment);
  void Need(size_t bytes, const char* field) const;

  const uint8_t* data_;  // after the encapsulation header
  size_t size_ = 0, position_ = 0;
  std::string where_;
};

class CdrWriter {
 public:
  CdrWriter();  // writes the encapsulation header

  template <typename T>
  void Write(T value) {
    static_assert(std::is_arithmetic_v<T>);
    Align(sizeof(T));
    const size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &value, sizeof(T));
  }
  void WriteBool(bool value) { Write<uint8_t>(value ? 1 : 0); }
  void String(const std::string& text);
  void SequenceLength(size_t count);
  void Bytes(const uint8_t* data, size_t size);

  std::vector<uint8_t> Take() { return std::move(bytes_); }

 private:
  void Align(size_t alignment);
  std::vector<uint8_t> bytes_;
};

}  // namespace furn
