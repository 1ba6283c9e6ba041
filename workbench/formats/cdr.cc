#include "workbench/formats/cdr.h"

#include "core/util/error.h"

namespace furn {
namespace {
constexpr size_t kEncapsulationBytes = 4;
}  // namespace

CdrReader::CdrReader(const uint8_t* data, size_t size, std::string where)
    : where_(std::move(where)) {
  Require(size >= kEncapsulationBytes,
          where_ + ": " + std::to_string(size) + " bytes, too short for a CDR message");
  // Byte 1: 0x00 big-endian CDR, 0x01 little-endian CDR; 0x02/0x03 are
  // parameter lists (mutable types), which no message read here uses.
  Require(data[0] == 0 && data[1] == 1,
          where_ + ": encapsulation " + std::to_string(data[0]) + "," + std::to_string(data[1]) +
              " is not little-endian plain CDR (0,1)");
  data_ = data + kEncapsulationBytes;
  size_ = size - kEncapsulationBytes;
}

void CdrReader::Align(size_t alignment) {
  const size_t padded = (position_ + alignment - 1) / alignment * alignment;
  position_ = padded <= size_ ? padded : size_;
}

void CdrReader::Need(size_t bytes, const char* field) const {
  Require(bytes <= size_ - position_,
          where_ + ": " + field + " needs " + std::to_string(bytes) + " bytes at offset " +
              std::to_string(position_ + kEncapsulationBytes) + " but the message ends at " +
              std::to_string(size_ + kEncapsulationBytes));
}

std::string CdrReader::String(const char* field, uint32_t max_bytes) {
  const uint32_t length = Read<uint32_t>(field);  // with the NUL
  Require(length <= max_bytes,
          where_ + ": " + field + " claims " + std::to_string(length) + " bytes, more than " +
              std::to_string(max_bytes));
  Need(length, field);
  if (length == 0) return std::string();  // some writers omit the NUL of ""
  Require(data_[position_ + length - 1] == 0, where_ + ": " + field + " lacks its closing NUL");
  std::string text(reinterpret_cast<const char*>(data_ + position_), length - 1);
  position_ += length;
  return text;
}

uint32_t CdrReader::SequenceLength(const char* field, size_t min_element_bytes) {
  const uint32_t count = Read<uint32_t>(field);
  Require(min_element_bytes == 0 || count <= remaining() / min_element_bytes,
          where_ + ": " + field + " claims " + std::to_string(count) + " elements of at least " +
              std::to_string(min_element_bytes) + " bytes; " + std::to_string(remaining()) +
              " bytes remain");
  return count;
}

std::pair<const uint8_t*, size_t> CdrReader::Bytes(const char* field) {
  const uint32_t count = SequenceLength(field, 1);
  const uint8_t* start = data_ + position_;
  position_ += count;
  return {start, count};
}

CdrWriter::CdrWriter() : bytes_{0, 1, 0, 0} {}

void CdrWriter::Align(size_t alignment) {
  const size_t position = bytes_.size() - kEncapsulationBytes;
  const size_t padded = (position + alignment - 1) / alignment * alignment;
  bytes_.resize(padded + kEncapsulationBytes, 0);
}

void CdrWriter::String(const std::string& text) {
  Write<uint32_t>(static_cast<uint32_t>(text.size() + 1));
  bytes_.insert(bytes_.end(), text.begin(), text.end());
  bytes_.push_back(0);
}

void CdrWriter::SequenceLength(size_t count) { Write<uint32_t>(static_cast<uint32_t>(count)); }

void CdrWriter::Bytes(const uint8_t* data, size_t size) {
  SequenceLength(size);
  bytes_.insert(bytes_.end(), data, data + size);
}

}  // namespace furn
