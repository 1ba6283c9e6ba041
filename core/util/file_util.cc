#include "core/util/file_util.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/util/error.h"

namespace furn {

void RequireRegularFile(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return;  // missing: the caller says so in its words
  if (S_ISREG(info.st_mode)) return;
  const char* kind = S_ISDIR(info.st_mode)    ? "a directory"
                     : S_ISFIFO(info.st_mode) ? "a FIFO"
                     : S_ISCHR(info.st_mode)  ? "a character device"
                     : S_ISBLK(info.st_mode)  ? "a block device"
                     : S_ISSOCK(info.st_mode) ? "a socket"
                                              : "not a regular file";
  throw InputError(path + ": cannot read (" + kind + "; inputs must be regular files)");
}

std::string ReadFileBytes(const std::string& path) {
  RequireRegularFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read (" + std::strerror(errno) + ")");
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path + ": cannot read (" + ec.message() + ")");
  std::string bytes(static_cast<size_t>(size), '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (in.bad() || static_cast<std::uintmax_t>(in.gcount()) != size)
    throw InputError(path + ": read error (the file changed while being read?)");
  return bytes;
}

void MakeDirectories(const std::string& dir, const std::string& what) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  Require(!error, dir + ": cannot create the " + what + " (" + error.message() + ")");
}

void WriteDirectoryAtomically(const std::string& out,
                              const std::function<void(const std::string& dir)>& write) {
  namespace fs = std::filesystem;
  const fs::path target(out);
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  Require(fs::is_directory(parent, ec),
          out + ": cannot write (directory " + parent.string() + " does not exist)");
  Require(!fs::exists(target, ec) || fs::is_directory(target, ec),
          out + ": cannot write a directory there (a file of that name exists)");
  const fs::path temp =
      parent / (target.filename().string() + ".tmp-" + std::to_string(::getpid()));
  fs::remove_all(temp, ec);
  Require(fs::create_directory(temp, ec), out + ": cannot write (" + ec.message() + ")");
  try {
    write(temp.string());
  } catch (...) {
    fs::remove_all(temp, ec);
    throw;
  }
  if (!fs::exists(target, ec)) {
    fs::rename(temp, target, ec);
    Require(!ec, out + ": cannot write (" + ec.message() + ")");
    return;
  }
  // Merge into the existing directory, entry by entry.
  for (const fs::directory_entry& entry : fs::directory_iterator(temp)) {
    const fs::path destination = target / entry.path().filename();
    if (fs::is_directory(destination, ec) && entry.is_directory()) fs::remove_all(destination, ec);
    fs::rename(entry.path(), destination, ec);
    Require(!ec, destination.string() + ": cannot write (" + ec.message() + ")");
  }
  fs::remove_all(temp, ec);
}

MappedFile::MappedFile(const std::string& path) {
  RequireRegularFile(path);  // open() of a FIFO would wait for a writer
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path + ": cannot read (" + std::strerror(errno) + ")");
  struct stat info {};
  if (::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
    ::close(fd);
    throw InputError(path + ": cannot read (not a regular file)");
  }
  size_ = static_cast<size_t>(info.st_size);
  if (size_ > 0) {
    void* mapped = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
    if (mapped == MAP_FAILED) {
      const int error = errno;
      ::close(fd);
      throw InputError(path + ": cannot read (" + std::strerror(error) + ")");
    }
    data_ = static_cast<const char*>(mapped);
  }
  ::close(fd);
}

MappedFile::~MappedFile() {
  if (data_ != nullptr) ::munmap(const_cast<char*>(data_), size_);
}

namespace {

// The null device under any of its names (/dev/null, a link to it).
bool IsNullDevice(const std::string& path) {
  struct stat target {};
  struct stat null_device {};
  return ::stat(path.c_str(), &target) == 0 && ::stat("/dev/null", &null_device) == 0 &&
         S_ISCHR(target.st_mode) && target.st_rdev == null_device.st_rdev;
}

}  // namespace

AtomicFile::AtomicFile(std::string path)
    : path_(std::move(path)), temp_path_(path_ + ".tmp-" + std::to_string(::getpid())) {
  Require(path_ != "-", "-: this output cannot go to standard output; name a file");
  const std::filesystem::path parent = std::filesystem::path(path_).parent_path();
  std::error_code ec;
  if (!parent.empty() && !std::filesystem::is_directory(parent, ec)) {
    throw InputError(path_ + ": cannot write (directory " + parent.string() + " does not exist)");
  }
  if (IsNullDevice(path_)) {  // `--out /dev/null`: written, then gone
    discard_ = true;
    temp_path_ = path_;
    return;
  }
  // A device, FIFO or socket is never replaced by a regular file (as root,
  // a rename over /dev/stdout would replace the device node).
  const std::filesystem::file_status status = std::filesystem::status(path_, ec);
  if (!ec && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status)) {
    throw InputError(path_ + ": cannot write (not a regular file; outputs are regular files, " +
                     "or '-' for standard output where a command offers it)");
  }
}

namespace {

// Flushes a file's or a folder's data to the disk (a power cut after the
// rename then leaves the new content, never an empty file).
void SyncPath(const std::string& path, int flags) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC);
  if (fd < 0) return;  // e.g. a folder that cannot be opened: the rename still happened
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

AtomicFile::~AtomicFile() {
  if (!committed_ && !discard_) std::remove(temp_path_.c_str());
}

void AtomicFile::Commit() {
  if (discard_) {
    committed_ = true;
    return;
  }
  std::error_code ec;
  if (!std::filesystem::exists(temp_path_, ec)) {
    throw InputError(path_ + ": cannot write (nothing was written)");
  }
  SyncPath(temp_path_, O_RDONLY);
  std::filesystem::rename(temp_path_, path_, ec);
  if (ec) throw InputError(path_ + ": cannot write (" + ec.message() + ")");
  committed_ = true;
  const std::filesystem::path parent = std::filesystem::path(path_).parent_path();
  SyncPath(parent.empty() ? "." : parent.string(), O_RDONLY | O_DIRECTORY);
}

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  if (path == "-") {  // standard output: written in place, a pipe or a terminal
    if (std::fwrite(bytes.data(), 1, bytes.size(), stdout) != bytes.size() ||
        std::fflush(stdout) != 0)
      throw InputError("-: cannot write to standard output (" + std::string(std::strerror(errno)) +
                       ")");
    return;
  }
  AtomicFile file(path);
  {
    std::ofstream out(file.TempPath(), std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path + ": cannot write (" + std::strerror(errno) + ")");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) throw InputError(path + ": cannot write (disk full or I/O error)");
  }
  file.Commit();
}

std::string FileExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return ext;
}

}  // namespace furn
