// Small file helpers that every layer needs: reading a whole file with an
// error that names it, and writing a file atomically so that an interrupted
// or failed write never leaves a half-written output behind.
//
//   std::string bytes = ReadFileBytes("model.obj");
//   WriteFileAtomically("out/summary.json", text);
//   AtomicFile file("out/mesh.ply");      // write file.TempPath() ...
//   file.Commit();                         // ... then rename into place
#pragma once

#include <cstddef>
#include <functional>
#include <string>

namespace furn {

// Throws InputError "<path>: cannot read (<reason>)", also for anything but
// a regular file (RequireRegularFile).
std::string ReadFileBytes(const std::string& path);

// Throws InputError "<path>: cannot read (a FIFO; inputs must be regular
// files)" when `path` (symlinks followed) exists and is not a regular file:
// opening a FIFO waits for a writer forever, and /dev/zero never ends.
// A missing path passes: callers say "does not exist" in their own words.
void RequireRegularFile(const std::string& path);

// Creates `dir` and its parents; InputError "<dir>: cannot create the <what>
// (<reason>)" when it cannot.
void MakeDirectories(const std::string& dir, const std::string& what);

// Runs `write(dir)` into a fresh temporary directory beside `out` and, when it
// returns, moves what it wrote into `out` (created if missing; files of the
// same names replaced, others kept). When it throws, the temporary directory
// is removed and `out` is untouched: no half-written report or export.
void WriteDirectoryAtomically(const std::string& out,
                              const std::function<void(const std::string& dir)>& write);

// A regular file mapped read-only into memory (mmap): large files are read
// without a copy. Throws InputError as ReadFileBytes does, and for a file
// that is not regular (a FIFO, a device) or changes size while mapped.
class MappedFile {
 public:
  explicit MappedFile(const std::string& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const char* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  const char* data_ = nullptr;
  size_t size_ = 0;
};

// Writes to "<path>.tmp-<pid>", syncs it to the disk, renames it over
// `path` and syncs the folder (a power cut leaves the old file or the new
// one, never an empty one); throws InputError naming `path` on failure and
// removes the temporary file. "-" writes to standard output instead. An
// existing `path` that is not a regular file (a device, a FIFO) is refused,
// never replaced, except the null device (/dev/null or a name of it), which
// is written to and discards what it gets.
void WriteFileAtomically(const std::string& path, const std::string& bytes);

// For writers that need a path rather than bytes (assimp, OpenCV, PCL):
// write to TempPath(), then Commit() (synced as above). Destroyed without
// Commit(), the temporary file is removed and `path` is untouched. Refuses
// "-" and a `path` that exists and is not a regular file but the null
// device: for it TempPath() is the device itself and Commit() renames nothing.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& TempPath() const { return temp_path_; }
  void Commit();

 private:
  std::string path_;
  std::string temp_path_;
  bool committed_ = false;
  bool discard_ = false;  // `path` is the null device
};

// Lower-case extension without the dot ("PLY" -> "ply"), "" when none.
std::string FileExtension(const std::string& path);

}  // namespace furn
