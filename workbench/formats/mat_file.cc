#include "workbench/formats/mat_file.h"

#include <zlib.h>

#include <cstring>
#include <filesystem>

#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {
namespace {

// MAT-file data types (the tag's type field) and array classes, from
// MathWorks' "MAT-File Format" (level 5).
enum MatType : uint32_t {
  kMiInt8 = 1,
  kMiUint8 = 2,
  kMiInt16 = 3,
  kMiUint16 = 4,
  kMiInt32 = 5,
  kMiUint32 = 6,
  kMiSingle = 7,
  kMiDouble = 9,
  kMiInt64 = 12,
  kMiUint64 = 13,
  kMiMatrix = 14,
  kMiCompressed = 15,
};
// Array classes not read: cell, struct, object, char, sparse.
constexpr uint32_t kSkippedClasses[] = {1, 2, 3, 4, 5};
constexpr uint32_t kComplexFlag = 0x0800;
constexpr size_t kHeaderBytes = 128;

// A bounded little-endian reader over bytes; every read checks what is left.
class MatReader {
 public:
  MatReader(const char* data, size_t size, std::string what)
      : data_(data), size_(size), what_(std::move(what)) {}

  bool AtEnd() const { return position_ >= size_; }
  size_t position() const { return position_; }

  uint32_t U32() {
    Need(4, "a 4-byte field");
    uint32_t value;
    std::memcpy(&value, data_ + position_, 4);
    position_ += 4;
    return value;
  }
  const char* Take(size_t bytes, const std::string& field) {
    Need(bytes, field);
    const char* at = data_ + position_;
    position_ += bytes;
    return at;
  }
  void SkipPadding() { position_ = std::min(size_, (position_ + 7) / 8 * 8); }
  [[noreturn]] void Fail(const std::string& rule) const {
    throw InputError(what_ + ": " + rule + " (at byte " + std::to_string(position_) + ")");
  }
  const std::string& what() const { return what_; }

 private:
  void Need(size_t bytes, const std::string& field) const {
    if (bytes > size_ - std::min(position_, size_))
      Fail(field + " of " + std::to_string(bytes) + " bytes runs past the end");
  }

  const char* data_;
  size_t size_;
  size_t position_ = 0;
  std::string what_;
};

// One data element: its type and bytes. Small elements (MAT-file's packed
// form) keep type and size in the first word and their data in the second.
struct MatElement {
  uint32_t type = 0;
  const char* data = nullptr;
  size_t bytes = 0;
};

MatElement ReadElement(MatReader& reader, bool pad) {
  const uint32_t first = reader.U32();
  MatElement element;
  if (first >> 16) {
    element.type = first & 0xffff;
    element.bytes = first >> 16;
    if (element.bytes > 4) reader.Fail("a small data element holds more than 4 bytes");
    element.data = reader.Take(4, "a small data element");
    return element;
  }
  element.type = first;
  element.bytes = reader.U32();
  element.data = reader.Take(element.bytes, "a data element");
  if (pad) reader.SkipPadding();
  return element;
}

// Inflates a miCOMPRESSED element, growing the output as it arrives (never
// to a size a header claims) and refusing more than kMaxMatElementBytes.
std::string Inflate(const MatElement& element, const std::string& what) {
  z_stream stream{};
  if (inflateInit(&stream) != Z_OK) throw InputError(what + ": zlib cannot start");
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(element.data));
  stream.avail_in = static_cast<uInt>(element.bytes);
  std::string out;
  int status = Z_OK;
  while (status == Z_OK) {
    if (out.size() >= kMaxMatElementBytes) {
      inflateEnd(&stream);
      throw InputError(what + ": a compressed element inflates past " +
                       std::to_string(kMaxMatElementBytes >> 20) + " MiB");
    }
    const size_t used = out.size();
    out.resize(std::min<uint64_t>(kMaxMatElementBytes, std::max<size_t>(4096, 2 * used)));
    stream.next_out = reinterpret_cast<Bytef*>(out.data() + used);
    stream.avail_out = static_cast<uInt>(out.size() - used);
    status = inflate(&stream, Z_NO_FLUSH);
    out.resize(out.size() - stream.avail_out);
    if (status == Z_BUF_ERROR && stream.avail_in == 0) break;  // truncated stream
    if (status == Z_BUF_ERROR) status = Z_OK;
  }
  inflateEnd(&stream);
  if (status != Z_STREAM_END)
    throw InputError(what + ": a compressed element is not a whole zlib stream");
  return out;
}

template <typename T>
void Append(const MatElement& element, std::vector<double>* values) {
  const size_t count = element.bytes / sizeof(T);
  values->reserve(count);
  for (size_t i = 0; i < count; ++i) {
    T value;
    std::memcpy(&value, element.data + i * sizeof(T), sizeof(T));
    values->push_back(static_cast<double>(value));
  }
}

size_t TypeBytes(uint32_t type) {
  switch (type) {
    case kMiInt8:
    case kMiUint8:
      return 1;
    case kMiInt16:
    case kMiUint16:
      return 2;
    case kMiInt32:
    case kMiUint32:
    case kMiSingle:
      return 4;
    case kMiDouble:
    case kMiInt64:
    case kMiUint64:
      return 8;
    default:
      return 0;
  }
}

std::vector<double> NumericValues(const MatElement& element, const std::string& where) {
  const size_t size = TypeBytes(element.type);
  if (size == 0)
    throw InputError(where + ": data type " + std::to_string(element.type) + " is not numeric");
  if (element.bytes % size != 0)
    throw InputError(where + ": " + std::to_string(element.bytes) +
                     " bytes are not a whole number of values");
  std::vector<double> values;
  switch (element.type) {
    case kMiInt8:
      Append<int8_t>(element, &values);
      break;
    case kMiUint8:
      Append<uint8_t>(element, &values);
      break;
    case kMiInt16:
      Append<int16_t>(element, &values);
      break;
    case kMiUint16:
      Append<uint16_t>(element, &values);
      break;
    case kMiInt32:
      Append<int32_t>(element, &values);
      break;
    case kMiUint32:
      Append<uint32_t>(element, &values);
      break;
    case kMiSingle:
      Append<float>(element, &values);
      break;
    case kMiDouble:
      Append<double>(element, &values);
      break;
    case kMiInt64:
      Append<int64_t>(element, &values);
      break;
    default:
      Append<uint64_t>(element, &values);
      break;
  }
  return values;
}

std::vector<int64_t> Dimensions(const MatElement& element, const std::string& where) {
  if (element.type != kMiInt32 || element.bytes < 8 || element.bytes % 4 != 0)
    throw InputError(where + ": dimensions must be two or more 32-bit integers");
  std::vector<int64_t> dimensions;
  for (size_t i = 0; i < element.bytes; i += 4) {
    int32_t d;
    std::memcpy(&d, element.data + i, 4);
    if (d < 0) throw InputError(where + ": a negative dimension " + std::to_string(d));
    dimensions.push_back(d);
  }
  return dimensions;
}

// A miMATRIX element: flags, dimensions, name, real part. Returns false for
// the classes skipped (cells, structs, objects, text, sparse, complex).
bool ReadMatrix(const MatElement& matrix,
                const std::string& what,
                std::string* name,
                MatArray* array) {
  MatReader reader(matrix.data, matrix.bytes, what);
  const MatElement flags = ReadElement(reader, true);
  if (flags.type != kMiUint32 || flags.bytes != 8) reader.Fail("array flags must be 8 bytes");
  uint32_t flag_word;
  std::memcpy(&flag_word, flags.data, 4);
  const MatElement dims = ReadElement(reader, true);
  const MatElement name_element = ReadElement(reader, true);
  if (name_element.type != kMiInt8) reader.Fail("an array name must be 8-bit text");
  *name = std::string(name_element.data, name_element.bytes);
  const std::string where = what + ": variable '" + *name + "'";
  const uint32_t array_class = flag_word & 0xff;
  for (uint32_t skipped : kSkippedClasses) {
    if (array_class == skipped) return false;
  }
  if ((flag_word & kComplexFlag) != 0) return false;
  array->dimensions = Dimensions(dims, where);
  uint64_t count = 1;
  for (int64_t d : array->dimensions) {
    count *= static_cast<uint64_t>(d);
    if (count > kMaxMatElementBytes) throw InputError(where + ": dimensions too large");
  }
  array->values = NumericValues(ReadElement(reader, true), where);
  if (array->values.size() != count)
    throw InputError(where + ": " + std::to_string(array->values.size()) +
                     " values for dimensions holding " + std::to_string(count));
  return true;
}

void AddMatrix(const MatElement& matrix, const std::string& what, MatArrays* arrays) {
  std::string name;
  MatArray array;
  if (!ReadMatrix(matrix, what, &name, &array)) return;
  if (!arrays->emplace(name, std::move(array)).second)
    throw InputError(what + ": variable '" + name + "' appears twice");
}

}  // namespace

MatArrays ParseMatFile(const std::string& bytes, const std::string& what) {
  if (bytes.size() < kHeaderBytes || bytes.compare(0, 10, "MATLAB 5.0") != 0)
    throw InputError(what +
                     ": not a MATLAB 5.0 MAT-file (a level-5 header is needed; "
                     "-v7.3 files are HDF5: save with -v7)");
  if (bytes[126] != 'I' || bytes[127] != 'M')
    throw InputError(what + ": a big-endian MAT-file; only little-endian files are read");
  MatReader reader(bytes.data() + kHeaderBytes, bytes.size() - kHeaderBytes, what);
  MatArrays arrays;
  while (!reader.AtEnd()) {
    // Compressed elements follow each other unpadded; others end on 8 bytes.
    MatElement element = ReadElement(reader, false);
    if (element.type != kMiCompressed) reader.SkipPadding();
    if (element.type == kMiCompressed) {
      const std::string inflated = Inflate(element, what);
      MatReader inner(inflated.data(), inflated.size(), what);
      const MatElement matrix = ReadElement(inner, false);
      if (matrix.type == kMiMatrix) AddMatrix(matrix, what, &arrays);
    } else if (element.type == kMiMatrix) {
      AddMatrix(element, what, &arrays);
    }
  }
  return arrays;
}

MatArrays ReadMatFile(const std::string& path) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  if (!error && size > kMaxMatFileBytes)
    throw InputError(path + ": a MAT-file of " + std::to_string(size >> 20) + " MiB; at most " +
                     std::to_string(kMaxMatFileBytes >> 20) + " MiB are read");
  return ParseMatFile(ReadFileBytes(path), path);
}

}  // namespace furn
