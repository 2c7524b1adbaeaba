#include "library_walk.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "mlspaces/core/error.h"

namespace mlspaces::internal {
namespace {

// The record getdents64 fills in (not exported by glibc's headers).
struct LinuxDirent64 {
  uint64_t d_ino;
  int64_t d_off;
  unsigned short d_reclen;
  unsigned char d_type;
  char d_name[];
};

bool StatIsDir(const std::string& path, bool* exists) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    *exists = false;
    return false;
  }
  *exists = true;
  return S_ISDIR(st.st_mode);
}

// Lists a folder with raw getdents64: open + getdents64 + close per folder, no fstat (opendir
// adds one), and the entry types come from d_type. Matters on filesystems where each syscall
// is expensive: a 10,000-asset library is 20,000 folders.
std::vector<WalkEntry> ListSorted(const std::string& abs) {
  int fd = ::open(abs.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    throw Error(std::string("cannot read folder: ") + std::strerror(errno), abs);
  }
  std::vector<WalkEntry> entries;
  alignas(8) char buf[32768];
  for (;;) {
    long n = ::syscall(SYS_getdents64, fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      int err = errno;
      ::close(fd);
      throw Error(std::string("cannot read folder: ") + std::strerror(err), abs);
    }
    if (n == 0) break;
    for (long off = 0; off < n;) {
      auto* e = reinterpret_cast<const LinuxDirent64*>(buf + off);
      off += e->d_reclen;
      const char* name = e->d_name;
      if (name[0] == '.' && (name[1] == '\0' || (name[1] == '.' && name[2] == '\0'))) continue;
      WalkEntry entry;
      entry.name = name;
      unsigned char type = e->d_type;
      if (type == DT_UNKNOWN) {
        struct stat st {};
        if (::fstatat(fd, name, &st, AT_SYMLINK_NOFOLLOW) == 0) {
          if (S_ISREG(st.st_mode))
            type = DT_REG;
          else if (S_ISDIR(st.st_mode))
            type = DT_DIR;
          else if (S_ISLNK(st.st_mode))
            type = DT_LNK;
        }
      }
      switch (type) {
        case DT_REG:
          entry.kind = WalkEntry::Kind::kFile;
          break;
        case DT_DIR:
          entry.kind = WalkEntry::Kind::kDir;
          break;
        case DT_LNK:
          entry.kind = WalkEntry::Kind::kSymlink;
          break;
        default:
          entry.kind = WalkEntry::Kind::kOther;
          break;
      }
      entries.push_back(std::move(entry));
    }
  }
  ::close(fd);
  std::sort(entries.begin(), entries.end(),
            [](const WalkEntry& a, const WalkEntry& b) { return a.name < b.name; });
  return entries;
}

void Walk(WalkDir& dir, const std::function<void(const WalkDir&, const WalkEntry&)>& visit) {
  dir.entries = ListSorted(dir.abs);
  for (const WalkEntry& entry : dir.entries) {
    switch (entry.kind) {
      case WalkEntry::Kind::kDir: {
        WalkDir child;
        child.rel = dir.RelChild(entry.name);
        child.abs = dir.AbsChild(entry.name);
        Walk(child, visit);
        break;
      }
      case WalkEntry::Kind::kSymlink: {
        bool exists = false;
        if (StatIsDir(dir.AbsChild(entry.name), &exists)) break;  // symlinked folder: skip
        visit(dir, entry);
        break;
      }
      default:
        visit(dir, entry);
        break;
    }
  }
}

}  // namespace

std::string WalkDir::RelChild(std::string_view name) const {
  std::string out;
  out.reserve(rel.size() + 1 + name.size());
  out += rel;
  if (!out.empty()) out += '/';
  out += name;
  return out;
}

std::string WalkDir::AbsChild(std::string_view name) const {
  std::string out;
  out.reserve(abs.size() + 1 + name.size());
  out += abs;
  if (out.empty() || out.back() != '/') out += '/';
  out += name;
  return out;
}

bool WalkDir::HasFile(std::string_view name) const {
  auto it = std::lower_bound(entries.begin(), entries.end(), name,
                             [](const WalkEntry& e, std::string_view n) { return e.name < n; });
  if (it == entries.end() || it->name != name) return false;
  switch (it->kind) {
    case WalkEntry::Kind::kFile:
      return true;
    case WalkEntry::Kind::kDir:
      return false;
    default: {
      bool exists = false;
      bool is_dir = StatIsDir(AbsChild(name), &exists);
      return exists && !is_dir;
    }
  }
}

void WalkSorted(const std::filesystem::path& root,
                const std::function<void(const WalkDir&, const WalkEntry&)>& visit) {
  std::error_code ec;
  auto status = std::filesystem::status(root, ec);
  if (ec || !std::filesystem::exists(status)) {
    throw Error("library folder not found (the original indexes it as empty; we refuse)",
                root.string());
  }
  if (!std::filesystem::is_directory(status)) throw Error("not a folder", root.string());
  WalkDir top;
  top.abs = root.string();
  Walk(top, visit);
}

void AppendJsonString(std::string& out, std::string_view s) {
  static constexpr char kHex[] = "0123456789abcdef";
  out += '"';
  for (char ch : s) {
    auto c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\b':
        out += "\\b";
        break;
      case '\f':
        out += "\\f";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20) {
          out += "\\u00";
          out += kHex[c >> 4];
          out += kHex[c & 0xf];
        } else {
          out += ch;
        }
    }
  }
  out += '"';
}

std::filesystem::path ResolvePath(const std::filesystem::path& p) {
  std::error_code ec;
  std::filesystem::path abs = std::filesystem::absolute(p, ec);
  if (ec) return p;
  std::filesystem::path canon = std::filesystem::weakly_canonical(abs, ec);
  return ec ? abs.lexically_normal() : canon;
}

std::filesystem::path IndexOutputPath(const std::filesystem::path& root,
                                      const std::filesystem::path& output,
                                      std::string_view default_name, bool overwrite) {
  std::filesystem::path path = output.empty() ? root / default_name : ResolvePath(output);
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !overwrite) {
    throw Error(path.string() + " already exists. Use --overwrite to overwrite.");
  }
  return path;
}

}  // namespace mlspaces::internal
