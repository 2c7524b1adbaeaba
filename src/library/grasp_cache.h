// The decoded grasp files a Registry has read, so repeated loads of one file (every episode of
// a datagen run, a Python loop over load_pickup_grasps) skip the zip and NPY parsing. An entry
// is used only while the file's identity and stamp (device, inode, size, mtime, ctime) are
// unchanged, so a rewritten file is read again; the cache holds at most `max_bytes` of poses,
// least recently used first out. Thread-safe.
#pragma once

#include <sys/stat.h>
#include <sys/types.h>

#include <cstddef>
#include <filesystem>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "mlspaces/library/grasp_set.h"

namespace mlspaces {

class GraspFileCache {
 public:
  explicit GraspFileCache(size_t max_bytes = size_t{256} << 20) : max_bytes_(max_bytes) {}

  /// Every grasp of the NPZ at `path` (ReadGraspFile), from the cache when the file is
  /// unchanged. @throws Error as ReadGraspFile, or when the file cannot be stat'ed.
  std::shared_ptr<const GraspSet> Get(const std::filesystem::path& path);
  /// As Get, but nullptr when there is no regular file at `path` (one stat either way).
  std::shared_ptr<const GraspSet> TryGet(const std::filesystem::path& path);

 private:
  struct Stamp {
    dev_t dev = 0;
    ino_t ino = 0;
    off_t size = 0;
    long long mtime_ns = 0, ctime_ns = 0;
    bool operator==(const Stamp&) const = default;
  };
  std::shared_ptr<const GraspSet> Load(const std::filesystem::path& path, const struct stat& st);

  struct Entry {
    Stamp stamp;
    std::shared_ptr<const GraspSet> grasps;
    size_t bytes = 0;
    std::list<std::string>::iterator lru;
  };

  std::mutex mu_;
  size_t max_bytes_;
  size_t bytes_ = 0;
  std::list<std::string> lru_;  // most recent first
  std::unordered_map<std::string, Entry> entries_;
};

}  // namespace mlspaces
