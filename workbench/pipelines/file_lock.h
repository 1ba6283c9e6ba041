// An exclusive lock on a file (made if missing) for as long as the object
// lives: flock(2), which NFS v4 and cluster filesystems honour across nodes,
// and which two threads of one process holding their own FileLock also feel.
//
//   const FileLock lock(dir + "/models/" + hash + ".lock");  // waits its turn
#pragma once

#include <string>

namespace furn {

class FileLock {
 public:
  // `what` names the locked thing in errors ("the model cache").
  FileLock(const std::string& path, const std::string& what);
  ~FileLock();  // releases the lock
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_;
};

}  // namespace furn
