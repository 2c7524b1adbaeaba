#include "grasp_cache.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "mlspaces/core/error.h"

namespace mlspaces {

std::shared_ptr<const GraspSet> GraspFileCache::Get(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw Error(std::string("cannot read the grasp file: ") + std::strerror(errno), path.string());
  }
  return Load(path, st);
}

std::shared_ptr<const GraspSet> GraspFileCache::TryGet(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return nullptr;
  return Load(path, st);
}

std::shared_ptr<const GraspSet> GraspFileCache::Load(const std::filesystem::path& path,
                                                     const struct stat& st) {
  const Stamp stamp{st.st_dev, st.st_ino, st.st_size,
                    st.st_mtim.tv_sec * 1000000000LL + st.st_mtim.tv_nsec,
                    st.st_ctim.tv_sec * 1000000000LL + st.st_ctim.tv_nsec};
  const std::string key = path.string();
  {
    std::lock_guard lock(mu_);
    auto it = entries_.find(key);
    if (it != entries_.end() && it->second.stamp == stamp) {
      lru_.splice(lru_.begin(), lru_, it->second.lru);
      return it->second.grasps;
    }
  }
  auto grasps = std::make_shared<const GraspSet>(ReadGraspFile(path));
  const size_t bytes = grasps->poses.size() * sizeof(Mat4) + 64;
  std::lock_guard lock(mu_);
  auto it = entries_.find(key);
  if (it != entries_.end()) {
    bytes_ -= it->second.bytes;
    lru_.erase(it->second.lru);
    entries_.erase(it);
  }
  if (bytes > max_bytes_) return grasps;  // too big to keep
  while (bytes_ + bytes > max_bytes_ && !lru_.empty()) {
    auto old = entries_.find(lru_.back());
    bytes_ -= old->second.bytes;
    entries_.erase(old);
    lru_.pop_back();
  }
  lru_.push_front(key);
  entries_.emplace(key, Entry{stamp, grasps, bytes, lru_.begin()});
  bytes_ += bytes;
  return grasps;
}

}  // namespace mlspaces
