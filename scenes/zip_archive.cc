#include "scenes/zip_archive.h"

#include <zip.h>

#include <zlib.h>
#include <mutex>

#include "core/geometry/mesh.h"
#include "core/util/error.h"
#include "core/util/file_util.h"

namespace furn {

// libzip's archive handle is not thread-safe; every call on it takes `mutex`,
// so models can be imported from one archive on several threads (the parsing
// happens outside, on the bytes read).
struct ZipArchive::Handle {
  zip_t* zip = nullptr;
  std::mutex mutex;
};

namespace {

std::string ZipErrorText(int code) {
  zip_error_t error;
  zip_error_init_with_code(&error, code);
  std::string text = zip_error_strerror(&error);
  zip_error_fini(&error);
  return text;
}

}  // namespace

ZipArchive::ZipArchive(const std::string& path) : path_(path), handle_(std::make_unique<Handle>()) {
  RequireRegularFile(path);
  int code = 0;
  handle_->zip = zip_open(path.c_str(), ZIP_RDONLY | ZIP_CHECKCONS, &code);
  if (handle_->zip == nullptr) {
    if (code == ZIP_ER_NOENT) throw InputError(path + ": file does not exist");
    throw InputError(path + ": not a readable zip archive (" + ZipErrorText(code) + ")");
  }
}

ZipArchive::~ZipArchive() {
  if (handle_->zip != nullptr) zip_discard(handle_->zip);
}

bool ZipArchive::Contains(const std::string& name) const {
  std::lock_guard<std::mutex> lock(handle_->mutex);
  return zip_name_locate(handle_->zip, name.c_str(), ZIP_FL_ENC_GUESS) >= 0;
}

std::string ZipArchive::Read(const std::string& name) const {
  std::lock_guard<std::mutex> lock(handle_->mutex);
  const std::string where = path_ + "!/" + name;
  const zip_int64_t index = zip_name_locate(handle_->zip, name.c_str(), ZIP_FL_ENC_GUESS);
  if (index < 0) throw InputError(where + ": no such entry in the archive");
  zip_stat_t stat;
  zip_stat_init(&stat);
  if (zip_stat_index(handle_->zip, index, 0, &stat) != 0 || !(stat.valid & ZIP_STAT_SIZE)) {
    throw InputError(where + ": cannot stat entry (" + zip_strerror(handle_->zip) + ")");
  }
  // Nothing is allocated for what the archive cannot hold: a model entry of
  // at most 512 MiB, and no more than deflate's largest expansion (1032:1)
  // of its compressed bytes (forged sizes and zip bombs).
  constexpr zip_uint64_t kMaxEntryBytes = 512ull << 20;
  if (stat.size > kMaxEntryBytes) {
    throw InputError(where + ": entry of " + std::to_string(stat.size) +
                     " bytes is larger than the 512 MiB a model file may have");
  }
  if ((stat.valid & ZIP_STAT_COMP_SIZE) && stat.size > 1032 * stat.comp_size + 65536) {
    throw InputError(where + ": entry expands " + std::to_string(stat.comp_size) + " bytes to " +
                     std::to_string(stat.size) +
                     ", beyond what deflate can (a forged size or a "
                     "zip bomb)");
  }
  zip_file_t* file = zip_fopen_index(handle_->zip, index, 0);
  if (file == nullptr) {
    throw InputError(where + ": cannot open entry (" + zip_strerror(handle_->zip) + ")");
  }
  std::string bytes(stat.size, '\0');
  zip_uint64_t done = 0;
  while (done < stat.size) {
    const zip_int64_t got = zip_fread(file, bytes.data() + done, stat.size - done);
    if (got <= 0) {
      const std::string reason = got < 0 ? zip_file_strerror(file) : "unexpected end of data";
      zip_fclose(file);
      throw InputError(where + ": corrupt entry (" + reason + ")");
    }
    done += static_cast<zip_uint64_t>(got);
  }
  const int close_code = zip_fclose(file);
  if (close_code != 0) {
    throw InputError(where + ": corrupt entry (" + ZipErrorText(close_code) + ")");
  }
  // libzip does not check the CRC of stored (uncompressed) entries; do it for
  // all.
  if (stat.valid & ZIP_STAT_CRC) {
    const uLong crc = crc32(crc32(0L, Z_NULL, 0),
                            reinterpret_cast<const Bytef*>(bytes.data()),
                            static_cast<uInt>(bytes.size()));
    if (crc != stat.crc) throw InputError(where + ": corrupt entry (CRC error)");
  }
  return bytes;
}

std::string ZipArchive::EntriesDigest(const std::string& prefix) const {
  std::lock_guard<std::mutex> lock(handle_->mutex);
  ContentHasher hasher;
  const zip_int64_t entries = zip_get_num_entries(handle_->zip, 0);
  for (zip_int64_t index = 0; index < entries; ++index) {
    zip_stat_t stat;
    zip_stat_init(&stat);
    if (zip_stat_index(handle_->zip, index, 0, &stat) != 0 || !(stat.valid & ZIP_STAT_NAME))
      continue;
    const std::string name = stat.name;
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const uint64_t size = (stat.valid & ZIP_STAT_SIZE) ? stat.size : 0;
    const uint32_t crc = (stat.valid & ZIP_STAT_CRC) ? stat.crc : 0;
    hasher.Update(name.data(), name.size() + 1);  // with its terminating NUL
    hasher.Update(&size, sizeof(size));
    hasher.Update(&crc, sizeof(crc));
  }
  return hasher.HexDigest();
}

}  // namespace furn
