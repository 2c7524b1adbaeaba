// .tar.zst: libarchive does the tar format, libzstd the compression.
//
// We compress and decompress with libzstd ourselves rather than through libarchive's zstd
// filter because libarchive 3.6 writes frames without a content checksum: a flipped byte in a
// file's data would then extract silently. Our frames carry the checksum, and reading drains
// the stream to its end so a damaged checksum, a truncation or trailing garbage after the
// tar end marker are all reported.
//
// Extraction never lets libarchive touch the file system: every member is checked here and
// written with openat() relative to a descriptor of `dest`, one path component at a time with
// O_NOFOLLOW, so neither a '..' nor a symlink planted by an earlier member can redirect a
// write outside `dest`.
#include "mlspaces/resources/archive.h"

#include <archive.h>
#include <archive_entry.h>
#include <fcntl.h>
#include <locale.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <cerrno>
#include <cstring>
#include <functional>
#include <memory>
#include <set>
#include <string_view>

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces {
namespace fs = std::filesystem;
namespace {

/// Closes a descriptor on scope exit.
struct Fd {
  int fd = -1;
  explicit Fd(int f = -1) : fd(f) {}
  ~Fd() { Reset(); }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  Fd(Fd&& o) noexcept : fd(o.fd) { o.fd = -1; }
  Fd& operator=(Fd&& o) noexcept {
    if (this != &o) {
      Reset();
      fd = o.fd;
      o.fd = -1;
    }
    return *this;
  }
  void Reset() {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
};

/// Splits a '/'-separated path; empty components are kept so callers can reject them.
std::vector<std::string> SplitPath(std::string_view path) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    const size_t slash = path.find('/', start);
    parts.emplace_back(path.substr(start, slash == std::string_view::npos ? slash : slash - start));
    if (slash == std::string_view::npos) return parts;
    start = slash + 1;
  }
}

/// Switches this thread to the C.UTF-8 locale for its lifetime. libarchive converts names
/// between the locale's charset and the UTF-8 of pax records; in the "C" locale a non-ASCII
/// name fails (or crashes libarchive 3.6). Thread-local, so nothing else is affected.
class Utf8Locale {
 public:
  Utf8Locale() {
    utf8_ = ::newlocale(LC_CTYPE_MASK, "C.UTF-8", nullptr);
    if (utf8_ != nullptr) old_ = ::uselocale(utf8_);
  }
  ~Utf8Locale() {
    if (utf8_ == nullptr) return;
    ::uselocale(old_);
    ::freelocale(utf8_);
  }
  Utf8Locale(const Utf8Locale&) = delete;
  Utf8Locale& operator=(const Utf8Locale&) = delete;

 private:
  locale_t utf8_ = nullptr;
  locale_t old_ = nullptr;
};

// ---------------------------------------------------------------------------------------
// Writing

struct WriteState {
  int fd = -1;
  ZSTD_CCtx* cctx = nullptr;
  std::vector<char> out = std::vector<char>(ZSTD_CStreamOutSize());
  std::string error;  // set by the callback; libarchive only sees "write failed"
  uint64_t written = 0;

  bool Compress(const void* data, size_t size, ZSTD_EndDirective mode) {
    ZSTD_inBuffer in{data, size, 0};
    for (;;) {
      ZSTD_outBuffer o{out.data(), out.size(), 0};
      const size_t left = ZSTD_compressStream2(cctx, &o, &in, mode);
      if (ZSTD_isError(left)) {
        error = std::string("zstd: ") + ZSTD_getErrorName(left);
        return false;
      }
      if (!WriteAll(fd, std::string_view(out.data(), o.pos))) {
        error = Errno("write failed");
        return false;
      }
      written += o.pos;
      if (mode == ZSTD_e_end ? left == 0 : in.pos == in.size) return true;
    }
  }
};

la_ssize_t WriteCallback(struct archive*, void* client, const void* buffer, size_t length) {
  auto* state = static_cast<WriteState*>(client);
  if (!state->Compress(buffer, length, ZSTD_e_continue)) return -1;
  return static_cast<la_ssize_t>(length);
}

void CheckMemberPath(const std::string& path, const std::string& archive) {
  for (const std::string& part : SplitPath(path)) {
    if (part.empty() || part == "." || part == "..") {
      throw Error(
          "member path must be relative, '/'-separated, without '.', '..' or empty "
          "components",
          archive, path);
    }
  }
}

// ---------------------------------------------------------------------------------------
// Reading

constexpr unsigned char kZstdMagic[4] = {0x28, 0xb5, 0x2f, 0xfd};

/// Feeds libarchive the decompressed stream.
struct ReadState {
  int fd = -1;
  ZSTD_DCtx* dctx = nullptr;
  std::vector<char> in_buf = std::vector<char>(ZSTD_DStreamInSize());
  std::vector<char> out_buf = std::vector<char>(ZSTD_DStreamOutSize());
  ZSTD_inBuffer in{nullptr, 0, 0};
  bool eof = false;
  size_t last_ret = 1;  // "inside a frame": an empty stream is truncated
  std::string error;

  /// Next decompressed block: >0 bytes, 0 at a clean end, -1 with `error` set.
  ssize_t Next(const void** buffer) {
    for (;;) {
      if (in.pos == in.size && !eof) {
        ssize_t n;
        do n = ::read(fd, in_buf.data(), in_buf.size());
        while (n < 0 && errno == EINTR);
        if (n < 0) {
          error = Errno("read failed");
          return -1;
        }
        in = {in_buf.data(), static_cast<size_t>(n), 0};
        eof = n == 0;
      }
      // Between frames with nothing left: the clean end. (Calling the decoder again here would
      // start a new frame and report it as unfinished.)
      if (in.pos == in.size && eof && last_ret == 0) return 0;
      ZSTD_outBuffer out{out_buf.data(), out_buf.size(), 0};
      const size_t ret = ZSTD_decompressStream(dctx, &out, &in);
      if (ZSTD_isError(ret)) {
        error = std::string("corrupt zstd stream: ") + ZSTD_getErrorName(ret);
        return -1;
      }
      last_ret = ret;
      if (out.pos > 0) {
        *buffer = out_buf.data();
        return static_cast<ssize_t>(out.pos);
      }
      if (in.pos == in.size && eof && ret != 0) {  // the file ends inside a frame
        error = "truncated zstd stream";
        return -1;
      }
    }
  }
};

la_ssize_t ReadCallback(struct archive* a, void* client, const void** buffer) {
  auto* state = static_cast<ReadState*>(client);
  const ssize_t n = state->Next(buffer);
  if (n < 0) archive_set_error(a, EIO, "%s", state->error.c_str());
  return n;
}

/// Names as UTF-8, or the raw bytes of a plain ustar name that is not UTF-8.
const char* Utf8OrRaw(const char* utf8, const char* raw) { return utf8 != nullptr ? utf8 : raw; }

/// One tar member, checked: `path` is normalised (no '.', no trailing '/').
struct Member {
  std::string path;
  std::vector<std::string> parts;
  enum Kind { kFile, kDir, kSymlink, kHardlink } kind = kFile;
  std::string link;  // symlink target (as stored) or hard link source (normalised)
  int64_t size = 0;
};

/// Iterates the members of a .tar.zst, checking names and types; `visit` may read the
/// current entry's data from `a`. The stream is drained to its end afterwards.
class TarReader {
 public:
  explicit TarReader(const fs::path& archive) : name_(archive.string()) {
    // (locale_ is constructed first: libarchive picks its charset conversions at creation.)
    fd_ = Fd(::open(archive.c_str(), O_RDONLY | O_CLOEXEC));
    if (fd_.fd < 0) throw Error(Errno("cannot open"), name_);
    unsigned char magic[4] = {};
    ssize_t n;
    do n = ::pread(fd_.fd, magic, sizeof magic, 0);
    while (n < 0 && errno == EINTR);
    if (n != 4 || std::memcmp(magic, kZstdMagic, 4) != 0) {
      throw Error("not a .tar.zst archive (no zstd frame header)", name_);
    }
    state_.fd = fd_.fd;
    dctx_.reset(ZSTD_createDCtx());
    state_.dctx = dctx_.get();
    owner_.reset(archive_read_new());
    a_ = owner_.get();
    if (state_.dctx == nullptr || a_ == nullptr) throw std::bad_alloc();
    archive_read_support_format_tar(a_);  // tar only: no cpio, zip, ... surprises
    if (archive_read_open(a_, &state_, nullptr, ReadCallback, nullptr) != ARCHIVE_OK) {
      Fail("cannot read archive");
    }
  }
  TarReader(const TarReader&) = delete;
  TarReader& operator=(const TarReader&) = delete;

  struct archive* handle() {
    return a_;
  }
  const std::string& name() const { return name_; }

  /// Throws an Error naming the archive and the member being read (or the last one read).
  [[noreturn]] void Fail(const std::string& what) {
    // Our own stream error first: libarchive replaces it with "Truncated input file".
    std::string detail = what;
    const char* err = archive_error_string(a_);
    if (!state_.error.empty()) {
      detail += ": " + state_.error;
    } else if (err != nullptr && *err != '\0') {
      detail += std::string(": ") + err;
    }
    std::string field = current_;
    if (field.empty()) {
      field = last_.empty() ? "" : "after member " + last_;
      if (last_.empty()) detail = "corrupt, truncated or not a tar archive: " + detail;
    }
    throw Error(detail, name_, field);
  }

  void ForEach(const std::function<void(const Member&)>& visit) {
    std::set<std::string> files;  // regular files seen so far: valid hard link sources
    for (;;) {
      struct archive_entry* entry = nullptr;
      current_.clear();
      const int r = archive_read_next_header(a_, &entry);
      if (r == ARCHIVE_EOF) break;
      if (r < ARCHIVE_WARN) Fail("cannot read member header");
      const char* raw =
          Utf8OrRaw(archive_entry_pathname_utf8(entry), archive_entry_pathname(entry));
      current_ = raw == nullptr ? "" : raw;
      Member m = Check(entry, files);
      visit(m);
      if (m.kind == Member::kFile) files.insert(m.path);
      last_ = current_;
    }
    // libarchive stops at the tar end marker; read the rest so the zstd checksum of the last
    // frame and the end of the stream are verified too.
    const void* buffer;
    ssize_t n;
    while ((n = state_.Next(&buffer)) > 0) {}
    if (n < 0) throw Error(state_.error, name_, last_.empty() ? "" : "after member " + last_);
  }

 private:
  Member Check(struct archive_entry* entry, const std::set<std::string>& files) {
    const std::string raw = current_;
    if (raw.empty()) throw Error("member with an empty name", name_, "(empty)");
    if (raw[0] == '/') throw Error("absolute member path refused", name_, raw);
    Member m;
    for (const std::string& part : SplitPath(raw)) {
      if (part == "..") throw Error("member path with '..' refused", name_, raw);
      if (!part.empty() && part != ".") m.parts.push_back(part);
    }
    for (const std::string& p : m.parts) m.path += (m.path.empty() ? "" : "/") + p;

    m.size = archive_entry_size(entry);
    const char* hardlink =
        Utf8OrRaw(archive_entry_hardlink_utf8(entry), archive_entry_hardlink(entry));
    const mode_t type = archive_entry_filetype(entry);
    if (hardlink != nullptr) {
      m.kind = Member::kHardlink;
      // Only an earlier regular member may be linked: nothing outside `dest` can be reached.
      for (const std::string& part : SplitPath(hardlink)) {
        if (!part.empty() && part != ".") m.link += (m.link.empty() ? "" : "/") + part;
      }
      if (hardlink[0] == '/' || files.count(m.link) == 0) {
        throw Error(std::string("hard link to '") + hardlink +
                        "', which is not an earlier regular member, refused",
                    name_, raw);
      }
    } else if (type == AE_IFREG) {
      m.kind = Member::kFile;
    } else if (type == AE_IFDIR) {
      m.kind = Member::kDir;
    } else if (type == AE_IFLNK) {
      m.kind = Member::kSymlink;
      const char* target =
          Utf8OrRaw(archive_entry_symlink_utf8(entry), archive_entry_symlink(entry));
      m.link = target == nullptr ? "" : target;
      CheckSymlinkTarget(m, raw);
    } else {
      const char* what = type == AE_IFCHR    ? "character device"
                         : type == AE_IFBLK  ? "block device"
                         : type == AE_IFIFO  ? "FIFO"
                         : type == AE_IFSOCK ? "socket"
                                             : "member of unknown type";
      throw Error(std::string(what) + " refused", name_, raw);
    }
    // "./" (the root folder itself) is harmless; an empty name for anything else is not.
    if (m.parts.empty() && m.kind != Member::kDir) {
      throw Error("member with an empty name", name_, raw);
    }
    return m;
  }

  // A symlink target must be relative and of the form "../../a/b": leading '..' that stay
  // within `dest`, then only downward components. Lexically checking "a/../../x" is not
  // enough, because 'a' may itself be a symlink (to "b/c", say) and the kernel resolves '..'
  // from where 'a' points. With '..' only in front, they climb real folders (we never create
  // a folder through a symlink), and every later component resolves inside `dest` by the same
  // argument applied to the symlinks it meets.
  void CheckSymlinkTarget(const Member& m, const std::string& raw) {
    if (m.link.empty()) throw Error("symlink with an empty target refused", name_, raw);
    if (m.link[0] == '/') {
      throw Error("symlink to absolute path '" + m.link + "' refused", name_, raw);
    }
    size_t up = 0;
    bool down = false;
    for (const std::string& part : SplitPath(m.link)) {
      if (part.empty() || part == ".") continue;
      if (part == "..") {
        if (down) {
          throw Error("symlink target '" + m.link + "' has '..' after a name; refused", name_, raw);
        }
        ++up;
      } else {
        down = true;
      }
    }
    // The link lives in the folder parts[0..n-2], whose depth is parts.size() - 1.
    if (m.parts.empty() || up > m.parts.size() - 1) {
      throw Error("symlink target '" + m.link + "' leaves the destination; refused", name_, raw);
    }
  }

  Utf8Locale locale_;
  std::string name_;
  Fd fd_;
  ReadState state_;
  // Owned through unique_ptrs so that a throwing constructor frees them too.
  std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> dctx_{nullptr, ZSTD_freeDCtx};
  std::unique_ptr<struct archive, int (*)(struct archive*)> owner_{nullptr, archive_read_free};
  struct archive* a_ = nullptr;
  std::string current_, last_;
};

/// Opens (creating as 0755 where missing) the folder parts[0..count-1] under `root_fd`,
/// refusing to pass through symlinks or files.
Fd OpenDirs(int root_fd, const std::vector<std::string>& parts, size_t count,
            const std::string& archive, const std::string& member) {
  Fd cur(::dup(root_fd));
  if (cur.fd < 0) throw Error(Errno("dup failed"), archive, member);
  for (size_t i = 0; i < count; ++i) {
    const char* name = parts[i].c_str();
    int fd = ::openat(cur.fd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0 && errno == ENOENT) {
      if (::mkdirat(cur.fd, name, 0755) != 0 && errno != EEXIST) {
        throw Error(Errno("cannot create folder"), archive, member);
      }
      fd = ::openat(cur.fd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
      if (fd >= 0 && ::fchmod(fd, 0755) != 0) {
        ::close(fd);
        throw Error(Errno("cannot chmod folder"), archive, member);
      }
    }
    if (fd < 0) {
      if (errno == ELOOP || errno == ENOTDIR) {
        throw Error("member path passes through a symlink or a file ('" + parts[i] + "'); refused",
                    archive, member);
      }
      throw Error(Errno("cannot open folder"), archive, member);
    }
    cur = Fd(fd);
  }
  return cur;
}

}  // namespace

uint64_t WriteTarZst(const fs::path& out, std::span<const ArchiveMember> members,
                     const ArchiveWriteOptions& options) {
  const std::string name = out.string();
  std::set<std::string> seen;
  for (const ArchiveMember& m : members) {
    CheckMemberPath(m.path, name);
    if (!seen.insert(m.path).second) throw Error("duplicate member path", name, m.path);
  }
  if (!out.parent_path().empty()) {
    std::error_code ec;
    fs::create_directories(out.parent_path(), ec);
    if (ec) throw Error("cannot create folder: " + ec.message(), out.parent_path().string());
  }
  const std::string tmp = name + TempSuffix();
  Utf8Locale locale;
  WriteState state;
  state.fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (state.fd < 0) throw Error(Errno("cannot write"), name);
  state.cctx = ZSTD_createCCtx();
  struct archive* a = archive_write_new();
  // Everything below cleans up through this one guard; `committed` keeps the renamed file.
  bool committed = false;
  struct Cleanup {
    std::function<void()> run;
    ~Cleanup() { run(); }
  } cleanup{[&] {
    if (a != nullptr) archive_write_free(a);
    ZSTD_freeCCtx(state.cctx);
    if (state.fd >= 0) ::close(state.fd);
    if (!committed) ::unlink(tmp.c_str());
  }};
  if (a == nullptr || state.cctx == nullptr) throw std::bad_alloc();
  const int level = options.zstd_level;
  if (level < ZSTD_minCLevel() || level > ZSTD_maxCLevel()) {
    throw Error("zstd level " + std::to_string(level) + " out of range", name);
  }
  ZSTD_CCtx_setParameter(state.cctx, ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setParameter(state.cctx, ZSTD_c_checksumFlag, 1);
  auto fail = [&](const std::string& what, const std::string& field = {}) {
    std::string detail = what;
    if (!state.error.empty()) {
      detail += ": " + state.error;
    } else if (archive_error_string(a) != nullptr) {
      detail += std::string(": ") + archive_error_string(a);
    }
    throw Error(detail, name, field);
  };
  // pax_restricted: plain ustar headers unless a name needs a pax record (long, non-ASCII).
  if (archive_write_set_format_pax_restricted(a) != ARCHIVE_OK ||
      archive_write_open(a, &state, nullptr, WriteCallback, nullptr) != ARCHIVE_OK) {
    fail("cannot start archive");
  }
  std::vector<char> buffer(1 << 20);
  for (const ArchiveMember& m : members) {
    const std::string source = m.source.string();
    Fd in(::open(m.source.c_str(), O_RDONLY | O_CLOEXEC));
    struct stat st {};
    if (in.fd < 0 || ::fstat(in.fd, &st) != 0) throw Error(Errno("cannot open"), source);
    if (!S_ISREG(st.st_mode)) throw Error("not a regular file", source);
    std::unique_ptr<archive_entry, void (*)(archive_entry*)> entry(archive_entry_new(),
                                                                   archive_entry_free);
    archive_entry_set_pathname(entry.get(), m.path.c_str());
    archive_entry_set_filetype(entry.get(), AE_IFREG);
    archive_entry_set_perm(entry.get(), 0644);
    archive_entry_set_size(entry.get(), st.st_size);
    archive_entry_set_mtime(entry.get(), 0, 0);
    archive_entry_set_uid(entry.get(), 0);
    archive_entry_set_gid(entry.get(), 0);
    if (archive_write_header(a, entry.get()) != ARCHIVE_OK) fail("cannot write header", m.path);
    int64_t left = st.st_size;
    while (left > 0) {
      const ssize_t n = ::read(in.fd, buffer.data(), std::min<int64_t>(left, buffer.size()));
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw Error(Errno("cannot read"), source);
      if (n == 0) throw Error("file shrank while being archived", source);
      if (archive_write_data(a, buffer.data(), static_cast<size_t>(n)) != n) {
        fail("cannot write data", m.path);
      }
      left -= n;
    }
  }
  if (archive_write_close(a) != ARCHIVE_OK) fail("cannot finish archive");
  if (!state.Compress(nullptr, 0, ZSTD_e_end)) fail("cannot finish zstd stream");
  if (options.sync && ::fsync(state.fd) != 0) throw Error(Errno("fsync failed"), name);
  if (::close(state.fd) != 0) {
    state.fd = -1;
    throw Error(Errno("close failed"), name);
  }
  state.fd = -1;
  if (::rename(tmp.c_str(), out.c_str()) != 0) throw Error(Errno("cannot rename into place"), name);
  committed = true;
  CrashPoint("archive written");
  if (options.sync) {
    FsyncPath(out.parent_path().empty() ? fs::path(".") : out.parent_path(), true, name);
  }
  return state.written;
}

ExtractReport ExtractTarZst(const fs::path& archive, const fs::path& dest) {
  TarReader reader(archive);
  const std::string& name = reader.name();
  std::error_code ec;
  fs::create_directories(dest, ec);
  if (ec) throw Error("cannot create folder: " + ec.message(), dest.string());
  Fd root(::open(dest.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (root.fd < 0) throw Error(Errno("cannot open folder"), dest.string());

  ExtractReport report;
  reader.ForEach([&](const Member& m) {
    if (m.kind == Member::kDir) {
      OpenDirs(root.fd, m.parts, m.parts.size(), name, m.path);
      return;
    }
    Fd dir = OpenDirs(root.fd, m.parts, m.parts.size() - 1, name, m.path);
    const char* leaf = m.parts.back().c_str();
    if (m.kind == Member::kSymlink) {
      if (::symlinkat(m.link.c_str(), dir.fd, leaf) != 0) {
        throw Error(Errno("cannot create symlink"), name, m.path);
      }
    } else if (m.kind == Member::kHardlink) {
      const std::vector<std::string> src = SplitPath(m.link);
      Fd src_dir = OpenDirs(root.fd, src, src.size() - 1, name, m.path);
      if (::linkat(src_dir.fd, src.back().c_str(), dir.fd, leaf, 0) != 0) {
        throw Error(Errno("cannot create hard link"), name, m.path);
      }
    } else {
      // O_EXCL|O_NOFOLLOW: never reuse or follow whatever is already there (a duplicate
      // member, or a symlink an earlier member planted).
      Fd out(::openat(dir.fd, leaf, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600));
      if (out.fd < 0) {
        throw Error(errno == EEXIST ? std::string("member already exists (duplicate name?)")
                                    : Errno("cannot create file"),
                    name, m.path);
      }
      const void* block;
      size_t size;
      la_int64_t offset;
      for (;;) {
        const int r = archive_read_data_block(reader.handle(), &block, &size, &offset);
        if (r == ARCHIVE_EOF) break;
        if (r < ARCHIVE_WARN) reader.Fail("cannot read member data");
        // pwrite at libarchive's offset: sparse members come as blocks with holes between.
        const char* p = static_cast<const char*>(block);
        while (size > 0) {
          const ssize_t n = ::pwrite(out.fd, p, size, offset);
          if (n < 0 && errno == EINTR) continue;
          if (n < 0) throw Error(Errno("write failed"), name, m.path);
          p += n;
          offset += n;
          size -= static_cast<size_t>(n);
          report.bytes += static_cast<uint64_t>(n);
        }
      }
      if (::ftruncate(out.fd, static_cast<off_t>(m.size)) != 0) {  // a trailing hole
        throw Error(Errno("write failed"), name, m.path);
      }
      if (::fchmod(out.fd, 0444) != 0) throw Error(Errno("cannot chmod"), name, m.path);
    }
    report.files.push_back(m.path);
  });
  return report;
}

std::vector<std::string> ListTarZst(const fs::path& archive) {
  TarReader reader(archive);
  std::vector<std::string> files;
  reader.ForEach([&](const Member& m) {
    if (m.kind == Member::kFile || m.kind == Member::kHardlink) files.push_back(m.path);
    // Skipping the data still decompresses it, so corruption anywhere is still reported.
    if (archive_read_data_skip(reader.handle()) < ARCHIVE_WARN) {
      reader.Fail("cannot read member data");
    }
  });
  return files;
}

}  // namespace mlspaces
