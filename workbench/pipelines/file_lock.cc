#include "workbench/pipelines/file_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include "core/util/error.h"

namespace furn {

FileLock::FileLock(const std::string& path, const std::string& what)
    : fd_(open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644)) {
  Require(fd_ >= 0, path + ": cannot open " + what + "'s lock file");
  if (flock(fd_, LOCK_EX) != 0) {
    close(fd_);
    throw InputError(path + ": cannot lock " + what);
  }
}

FileLock::~FileLock() { close(fd_); }

}  // namespace furn
