#include "mlspaces/resources/archive.h"

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "mlspaces/resources/sha256.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::ListFiles;
using ::mlspaces::testing::Noise;
using ::mlspaces::testing::RunProgram;
using ::mlspaces::testing::RunPython;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::ElementsAre;
using ::testing::ElementsAreArray;
using ::testing::HasSubstr;

mode_t ModeOf(const fs::path& p) {
  struct stat st {};
  EXPECT_EQ(::lstat(p.c_str(), &st), 0) << p;
  return st.st_mode & 07777;
}

/// Sources for a typical package: text, binary, empty, a long name and a non-ASCII one.
struct Fixture {
  TempDir dir;
  std::vector<ArchiveMember> members;
  std::vector<std::string> contents;
  std::string long_name = "deep/" + std::string(120, 'n') + "/file.txt";

  Fixture() {
    Add("a.txt", "hello\n");
    Add("dir/sub/b.bin", Noise(100000, 1));
    Add("empty", "");
    Add(long_name, "long\n");
    Add("\xc3\xbc/\xc3\xb1.txt", "utf8\n");  // ü/ñ.txt
  }
  void Add(const std::string& path, const std::string& data) {
    const fs::path src = dir / ("src" + std::to_string(members.size()));
    WriteText(src, data);
    members.push_back({path, src});
    contents.push_back(data);
  }
  std::vector<std::string> Paths() const {
    std::vector<std::string> out;
    for (const auto& m : members) out.push_back(m.path);
    return out;
  }
};

TEST(Archive, RoundTrip) {
  Fixture f;
  const fs::path arc = f.dir / "out" / "pkg.tar.zst";
  const uint64_t size = WriteTarZst(arc, f.members);
  EXPECT_EQ(size, fs::file_size(arc));
  EXPECT_THAT(ListTarZst(arc), ElementsAreArray(f.Paths()));

  const fs::path dest = f.dir / "dest";
  const ExtractReport report = ExtractTarZst(arc, dest);
  EXPECT_THAT(report.files, ElementsAreArray(f.Paths()));
  uint64_t total = 0;
  for (size_t i = 0; i < f.members.size(); ++i) {
    const fs::path out = dest / f.members[i].path;
    EXPECT_EQ(Slurp(out), f.contents[i]) << f.members[i].path;
    EXPECT_EQ(ModeOf(out), 0444u) << f.members[i].path;
    total += f.contents[i].size();
  }
  EXPECT_EQ(report.bytes, total);
  EXPECT_EQ(ModeOf(dest / "dir"), 0755u);
  EXPECT_EQ(ModeOf(dest / "dir/sub"), 0755u);
  // No temp file is left beside the archive.
  EXPECT_THAT(ListFiles(f.dir / "out"), ElementsAre("pkg.tar.zst"));
}

TEST(Archive, SameInputsGiveSameBytes) {
  Fixture f;
  WriteTarZst(f.dir / "one.tar.zst", f.members);
  // Metadata of the sources must not leak in: change their modes and mtimes.
  for (const auto& m : f.members) {
    fs::permissions(m.source, fs::perms::owner_read | fs::perms::owner_write);
    fs::last_write_time(m.source, fs::file_time_type::clock::now() - std::chrono::hours(30));
  }
  WriteTarZst(f.dir / "two.tar.zst", f.members);
  const std::string one = Slurp(f.dir / "one.tar.zst");
  EXPECT_FALSE(one.empty());
  EXPECT_EQ(one, Slurp(f.dir / "two.tar.zst"));
  // A different level gives a valid archive too (and may differ in bytes).
  WriteTarZst(f.dir / "l19.tar.zst", f.members, {.zstd_level = 19});
  EXPECT_THAT(ListTarZst(f.dir / "l19.tar.zst"), ElementsAreArray(f.Paths()));
  ExpectError([&] { WriteTarZst(f.dir / "bad.tar.zst", f.members, {.zstd_level = 99}); },
              {"bad.tar.zst", "level 99"});
}

TEST(Archive, PythonTarfileReadsOurArchive) {
  Fixture f;
  const fs::path arc = f.dir / "pkg.tar.zst";
  WriteTarZst(arc, f.members);
  const auto r = RunProgram("zstd", {"-d", "-q", arc.string(), "-o", (f.dir / "pkg.tar").string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string out;
  ASSERT_EQ(RunPython(f.dir.path(), R"(
import hashlib, sys, tarfile
with tarfile.open(sys.argv[1]) as tf:
    for m in tf.getmembers():
        assert m.isfile() and m.mtime == 0 and m.uid == 0 and m.gid == 0, m
        assert m.mode == 0o644 and m.uname == "" and m.gname == "", m
        data = tf.extractfile(m).read()
        print(m.name, hashlib.sha256(data).hexdigest())
)",
                      testing::ShellQuote((f.dir / "pkg.tar").string()), &out),
            0);
  std::string expected;
  for (size_t i = 0; i < f.members.size(); ++i) {
    expected += f.members[i].path + " " + Sha256Hex(f.contents[i]) + "\n";
  }
  EXPECT_EQ(out, expected);
}

TEST(Archive, WriteErrorsNameTheMemberOrSource) {
  TempDir dir;
  WriteText(dir / "src", "x");
  std::vector<ArchiveMember> bad = {{"../x", dir / "src"}};
  ExpectError([&] { WriteTarZst(dir / "a.tar.zst", bad); }, {"a.tar.zst", "../x"});
  bad = {{"/abs", dir / "src"}};
  ExpectError([&] { WriteTarZst(dir / "a.tar.zst", bad); }, {"a.tar.zst", "/abs"});
  bad = {{"x", dir / "src"}, {"x", dir / "src"}};
  ExpectError([&] { WriteTarZst(dir / "a.tar.zst", bad); }, {"duplicate", "x"});
  bad = {{"ok", dir / "src"}, {"missing", dir / "nope"}};
  ExpectError([&] { WriteTarZst(dir / "a.tar.zst", bad); }, {(dir / "nope").string()});
  bad = {{"folder", dir.path()}};
  ExpectError([&] { WriteTarZst(dir / "a.tar.zst", bad); }, {"not a regular file"});
  // Nothing half-written is left behind.
  EXPECT_THAT(ListFiles(dir.path()), ElementsAre("src"));
}

// ---------------------------------------------------------------------------------------
// Archives built by Python's tarfile (which writes whatever it is told) and the zstd CLI.

/// Layout: root/arc (archives), root/outside (a file an attack would target), root/a/b/dest.
class Hostile : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteText(root_ / "outside" / "target.txt", "precious\n");
    dest_ = root_ / "a" / "b" / "dest";
    fs::create_directories(dest_);
  }

  /// Builds arc/<name>.tar.zst; `body` is Python run inside `with tarfile.open(...) as tf:`
  /// with helpers add(name, data), sym(name, target), hard(name, target), dev(name, type).
  fs::path Build(const std::string& name, const std::string& body) {
    const fs::path tar = root_ / "arc" / (name + ".tar");
    fs::create_directories(tar.parent_path());
    std::string script = R"(
import io, sys, tarfile
OUT, OUTSIDE = sys.argv[1], sys.argv[2]
def add(name, data=b"x", kind=tarfile.REGTYPE, link=""):
    ti = tarfile.TarInfo(name)
    ti.type, ti.linkname, ti.mode = kind, link, 0o644
    ti.size = len(data) if kind == tarfile.REGTYPE else 0
    tf.addfile(ti, io.BytesIO(data) if kind == tarfile.REGTYPE else None)
def sym(name, target): add(name, kind=tarfile.SYMTYPE, link=target)
def hard(name, target): add(name, kind=tarfile.LNKTYPE, link=target)
def folder(name): add(name, kind=tarfile.DIRTYPE)
with tarfile.open(OUT, "w", format=tarfile.PAX_FORMAT) as tf:
)";
    std::istringstream lines(body);
    for (std::string line; std::getline(lines, line);) script += "    " + line + "\n";
    EXPECT_EQ(RunPython(root_ / "arc", script,
                        testing::ShellQuote(tar.string()) + " " +
                            testing::ShellQuote((root_ / "outside").string())),
              0);
    fs::path zst = tar;
    zst += ".zst";
    const auto r = RunProgram("zstd", {"-q", "-f", "--rm", tar.string(), "-o", zst.string()});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return zst;
  }

  /// Extraction must fail naming the archive and `member`, and leave everything outside
  /// `dest` as it was.
  void ExpectRefused(const fs::path& arc, const std::string& member,
                     const std::string& reason = "") {
    std::vector<std::string> parts = {arc.string(), member};
    if (!reason.empty()) parts.push_back(reason);
    try {
      ExtractTarZst(arc, dest_);
      ADD_FAILURE() << "expected mlspaces::Error for " << arc;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      for (const std::string& p : parts) EXPECT_THAT(what, HasSubstr(p));
    }
    // Everything outside dest: the archives and the untouched target only.
    std::set<std::string> outside;
    for (const std::string& f : ListFiles(root_.path())) {
      if (f.rfind("a/b/dest/", 0) != 0 && f.rfind("arc/", 0) != 0) outside.insert(f);
    }
    EXPECT_THAT(outside, ElementsAre("outside/target.txt")) << arc;
    EXPECT_EQ(Slurp(root_ / "outside" / "target.txt"), "precious\n");
    EXPECT_FALSE(fs::exists(root_ / "a" / "b" / "x"));
    fs::remove_all(dest_);
    fs::create_directories(dest_);
  }

  TempDir root_;
  fs::path dest_;
};

TEST_F(Hostile, AbsolutePath) {
  ExpectRefused(Build("abs", "add('ok.txt')\nadd(OUTSIDE + '/abs.txt')"),
                (root_ / "outside" / "abs.txt").string(), "absolute");
}

TEST_F(Hostile, DotDotPaths) {
  ExpectRefused(Build("up", "add('../x')"), "../x", "'..'");
  ExpectRefused(Build("up2", "add('a/../../x')"), "a/../../x", "'..'");
  ExpectRefused(Build("up3", "folder('d')\nadd('d/../../../outside/target.txt', b'pwned')"),
                "d/../../../outside/target.txt");
}

TEST_F(Hostile, Symlinks) {
  ExpectRefused(Build("abslink", "sym('pw', '/etc/passwd')"), "pw", "absolute");
  ExpectRefused(Build("uplink", "sym('sub/up', '../../x')"), "sub/up", "leaves");
  ExpectRefused(Build("uplink2", "sym('up', '..')"), "up", "leaves");
  // Lexically inside ('p/q/s/../..' is '.'), but s -> '..' makes it climb out.
  ExpectRefused(Build("chain", "folder('p/q')\nsym('p/q/s', '..')\nsym('t', 'p/q/s/../../..')"),
                "t", "'..' after a name");
  // A link pointing out, then a file written through it.
  ExpectRefused(
      Build("through", "sym('link', '../../../outside')\nadd('link/target.txt', b'pwned')"),
      "link");
  // A link that is allowed (it stays inside), then a write through it: refused too.
  ExpectRefused(Build("through2", "folder('sub')\nsym('inlink', 'sub')\nadd('inlink/x')"),
                "inlink/x", "symlink");
  // A file over an earlier symlink is not followed.
  ExpectRefused(Build("over", "add('f', b'a')\nsym('l', 'f')\nadd('l', b'pwned')"), "l",
                "already exists");
}

TEST_F(Hostile, HardLinks) {
  ExpectRefused(Build("hardabs", "hard('h', OUTSIDE + '/target.txt')"), "h", "hard link");
  ExpectRefused(Build("hardup", "hard('h', '../../../outside/target.txt')"), "h", "hard link");
  ExpectRefused(Build("hardlater", "hard('h', 'f')\nadd('f')"), "h", "hard link");
  ExpectRefused(Build("hardsym", "sym('s', 'f')\nhard('h', 's')"), "h", "hard link");
}

TEST_F(Hostile, SpecialFiles) {
  ExpectRefused(Build("chr",
                      "ti = tarfile.TarInfo('null'); ti.type = tarfile.CHRTYPE\n"
                      "ti.devmajor, ti.devminor = 1, 3; tf.addfile(ti)"),
                "null", "character device");
  ExpectRefused(Build("blk",
                      "ti = tarfile.TarInfo('sda'); ti.type = tarfile.BLKTYPE\n"
                      "tf.addfile(ti)"),
                "sda", "block device");
  ExpectRefused(Build("fifo", "add('fifo', kind=tarfile.FIFOTYPE)"), "fifo", "FIFO");
}

TEST_F(Hostile, SafeLinksAreExtracted) {
  const fs::path arc = Build("safe",
                             "add('data.txt', b'data')\nsym('docs/link', '../data.txt')\n"
                             "hard('docs/hard', 'data.txt')\nfolder('./')");
  const ExtractReport report = ExtractTarZst(arc, dest_);
  EXPECT_THAT(report.files, ElementsAre("data.txt", "docs/link", "docs/hard"));
  EXPECT_EQ(fs::read_symlink(dest_ / "docs/link"), "../data.txt");
  EXPECT_EQ(Slurp(dest_ / "docs/link"), "data");
  EXPECT_EQ(Slurp(dest_ / "docs/hard"), "data");
  EXPECT_EQ(fs::hard_link_count(dest_ / "data.txt"), 2u);
  EXPECT_THAT(ListTarZst(arc), ElementsAre("data.txt", "docs/hard"));
}

// ---------------------------------------------------------------------------------------
// Damaged streams

class Damaged : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteText(dir_ / "small", "small\n");
    WriteText(dir_ / "big", Noise(400000, 7));
    const std::vector<ArchiveMember> members = {{"small.txt", dir_ / "small"},
                                                {"big.bin", dir_ / "big"}};
    WriteTarZst(arc_, members);
    bytes_ = Slurp(arc_);
  }
  void Rewrite(const std::string& data) {
    fs::remove(arc_);
    WriteText(arc_, data);
  }
  /// Both extraction and listing fail with one line naming the archive and `member`.
  void ExpectBroken(const std::string& member, const std::string& reason = "") {
    fs::remove_all(dir_ / "dest");
    ExpectError([&] { ExtractTarZst(arc_, dir_ / "dest"); }, {arc_.string(), member, reason});
    ExpectError([&] { ListTarZst(arc_); }, {arc_.string(), member, reason});
  }
  TempDir dir_;
  fs::path arc_ = dir_ / "pkg.tar.zst";
  std::string bytes_;
};

TEST_F(Damaged, Truncated) {
  Rewrite(bytes_.substr(0, bytes_.size() / 2));
  ExpectBroken("big.bin", "truncated");
  // Cut just before the end: the data is all there but the frame's checksum is missing.
  Rewrite(bytes_.substr(0, bytes_.size() - 2));
  ExpectBroken("big.bin", "truncated");
  Rewrite(bytes_.substr(0, 20));
  ExpectBroken("", "truncated");
}

TEST_F(Damaged, FlippedByte) {
  for (size_t at : {bytes_.size() / 2, bytes_.size() - 1}) {
    std::string bad = bytes_;
    bad[at] = static_cast<char>(bad[at] ^ 0xff);
    Rewrite(bad);
    ExpectBroken("big.bin", "zstd");
  }
}

TEST_F(Damaged, TrailingGarbage) {
  Rewrite(bytes_ + "garbage");
  ExpectBroken("big.bin", "zstd");
}

TEST_F(Damaged, NotAnArchive) {
  Rewrite("just some text, not an archive\n");
  ExpectBroken("", "not a .tar.zst");
  // zstd, but not a tar inside.
  WriteText(dir_ / "plain.txt", std::string(5000, 'q'));
  const auto r =
      RunProgram("zstd", {"-q", "-f", (dir_ / "plain.txt").string(), "-o", arc_.string()});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ExpectBroken("", "not a tar archive");
  ExpectError([&] { ListTarZst(dir_ / "missing.tar.zst"); }, {"missing.tar.zst", "cannot open"});
}

TEST_F(Damaged, ExistingFileInDestIsNotOverwritten) {
  WriteText(dir_ / "dest" / "small.txt", "mine\n");
  ExpectError([&] { ExtractTarZst(arc_, dir_ / "dest"); }, {"small.txt", "already exists"});
  EXPECT_EQ(Slurp(dir_ / "dest" / "small.txt"), "mine\n");
}

}  // namespace
}  // namespace mlspaces
