#include "mlspaces/datagen/video.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>
#include <vector>

#include "mlspaces/core/error.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::ListFiles;
using ::mlspaces::testing::RunPython;
using ::mlspaces::testing::ShellQuote;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

constexpr double kFps = 1000.0 / 66.0;

/// A camera-like frame: a gradient moving with `t`, a moving square and a little noise.
std::vector<unsigned char> MakeFrame(int w, int h, int t) {
  std::vector<unsigned char> rgb(static_cast<size_t>(w) * h * 3);
  uint32_t state = 12345u + static_cast<uint32_t>(t) * 7919u;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      state = state * 1664525u + 1013904223u;
      const int noise = static_cast<int>(state >> 29) - 4;  // -4..3
      const bool square = std::abs(x - (w / 4 + 2 * t) % w) < w / 8 && std::abs(y - h / 2) < h / 6;
      int r = (x * 255 / w + 3 * t) % 256, g = y * 255 / h, b = square ? 230 : 60;
      unsigned char* p = &rgb[(static_cast<size_t>(y) * w + x) * 3];
      p[0] = static_cast<unsigned char>(std::clamp(r + noise, 0, 255));
      p[1] = static_cast<unsigned char>(std::clamp(g + noise, 0, 255));
      p[2] = static_cast<unsigned char>(std::clamp(b + noise, 0, 255));
    }
  }
  return rgb;
}

std::vector<unsigned char> Solid(int w, int h, unsigned char r, unsigned char g, unsigned char b) {
  std::vector<unsigned char> rgb(static_cast<size_t>(w) * h * 3);
  for (size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = r;
    rgb[i + 1] = g;
    rgb[i + 2] = b;
  }
  return rgb;
}

void WriteVideo(const fs::path& path, int w, int h, int frames, VideoOptions o = {}) {
  VideoWriter writer(path, w, h, std::move(o));
  for (int t = 0; t < frames; ++t) writer.AddFrame(MakeFrame(w, h, t).data());
  EXPECT_EQ(writer.frames(), frames);
  writer.Finish();
}

/// The boxes of an MP4, read with Debian's python (struct only, no FFmpeg): key=value lines.
std::map<std::string, std::string> Mp4Boxes(const TempDir& dir, const fs::path& mp4) {
  const std::string script = R"PY(
import struct, sys
data = open(sys.argv[1], 'rb').read()
def boxes(off, end):
    while off < end:
        size, typ = struct.unpack('>I4s', data[off:off + 8])
        hdr = 8
        if size == 1:
            size, hdr = struct.unpack('>Q', data[off + 8:off + 16])[0], 16
        elif size == 0:
            size = end - off
        assert size >= hdr and off + size <= end, (typ, size)
        yield typ.decode('latin1'), off + hdr, off + size
        off += size
def find(off, end, path):
    for t, s, e in boxes(off, end):
        if t == path[0]:
            return (s, e) if len(path) == 1 else find(s, e, path[1:])
    return None
print('top=' + ','.join(t for t, _, _ in boxes(0, len(data))))
s, e = find(0, len(data), ['ftyp'])
print('brand=' + data[s:s + 4].decode('latin1'))
s, e = find(0, len(data), ['moov', 'mvhd'])
assert data[s] == 0
print('creation_time=%d' % struct.unpack('>I', data[s + 4:s + 8])[0])
stbl = ['moov', 'trak', 'mdia', 'minf', 'stbl']
s, e = find(0, len(data), ['moov', 'trak', 'mdia', 'mdhd'])
assert data[s] == 0
print('mdhd_creation_time=%d' % struct.unpack('>I', data[s + 4:s + 8])[0])
print('timescale=%d' % struct.unpack('>I', data[s + 12:s + 16])[0])
s, e = find(0, len(data), stbl + ['stts'])
n = struct.unpack('>I', data[s + 4:s + 8])[0]
entries = [struct.unpack('>II', data[s + 8 + 8 * i:s + 16 + 8 * i]) for i in range(n)]
print('stts=' + ';'.join('%dx%d' % c for c in entries))
s, e = find(0, len(data), stbl + ['stsz'])
print('samples=%d' % struct.unpack('>I', data[s + 8:s + 12])[0])
print('ctts=%d' % (find(0, len(data), stbl + ['ctts']) is not None))
s, e = find(0, len(data), stbl + ['stsd'])
entry = s + 8
typ = data[entry + 4:entry + 8].decode('latin1')
w, h = struct.unpack('>HH', data[entry + 32:entry + 36])
print('codec=%s' % typ)
print('size=%dx%d' % (w, h))
s2, e2 = find(entry + 86, entry + struct.unpack('>I', data[entry:entry + 4])[0], ['avcC'])
print('profile=%d' % data[s2 + 1])
print('lavf_version=%d' % (b'Lavf5' in data))
)PY";
  std::string out;
  EXPECT_EQ(RunPython(dir.path(), script, ShellQuote(mp4.string()), &out), 0);
  std::map<std::string, std::string> kv;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);) {
    const size_t eq = line.find('=');
    if (eq != std::string::npos) kv[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return kv;
}

class VideoFrameCountTest : public ::testing::TestWithParam<int> {};

TEST_P(VideoFrameCountTest, ProbeCountsEveryFrameWritten) {
  TempDir dir;
  const int n = GetParam();
  const fs::path mp4 = dir / "episode_00000000_wrist_camera_batch_1_of_1.mp4";
  WriteVideo(mp4, 64, 48, n);
  const VideoInfo info = ProbeVideo(mp4);
  EXPECT_EQ(info.frames, n);
  EXPECT_EQ(info.width, 64);
  EXPECT_EQ(info.height, 48);
  EXPECT_NEAR(info.fps, kFps, 0.01);
  EXPECT_EQ(info.codec, "h264");
  EXPECT_THAT(ListFiles(dir.path()), ElementsAre(mp4.filename().string()));  // no temp left
}

INSTANTIATE_TEST_SUITE_P(Frames, VideoFrameCountTest, ::testing::Values(1, 2, 64));

TEST(VideoTest, Mp4BoxesReadWithPython) {
  TempDir dir;
  const fs::path mp4 = dir / "v.mp4";
  WriteVideo(mp4, 64, 48, 64);
  auto kv = Mp4Boxes(dir, mp4);
  EXPECT_EQ(kv["brand"], "isom");
  EXPECT_EQ(kv["codec"], "avc1");
  EXPECT_EQ(kv["size"], "64x48");
  EXPECT_EQ(kv["profile"], "100");  // High, as ffmpeg -pix_fmt yuv420p gives
  EXPECT_EQ(kv["samples"], "64");
  // 500/33 fps: every sample lasts timescale * 33 / 500 ticks.
  const int timescale = std::stoi(kv["timescale"]);
  ASSERT_EQ(timescale % 500, 0) << timescale;
  EXPECT_EQ(kv["stts"], "64x" + std::to_string(timescale / 500 * 33));
  EXPECT_EQ(kv["ctts"], "1");  // B-frames were used (and all of them flushed: 64 samples)
  EXPECT_EQ(kv["creation_time"], "0");
  EXPECT_EQ(kv["mdhd_creation_time"], "0");
  EXPECT_EQ(kv["lavf_version"], "0");
}

TEST(VideoTest, SameFramesGiveSameBytes) {
  TempDir dir;
  WriteVideo(dir / "a.mp4", 80, 64, 20);
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // a clock in the file would show
  WriteVideo(dir / "sub" / "b.mp4", 80, 64, 20);
  const std::string a = Slurp(dir / "a.mp4"), b = Slurp(dir / "sub" / "b.mp4");
  ASSERT_FALSE(a.empty());
  EXPECT_TRUE(a == b) << a.size() << " vs " << b.size();
  // The options are part of the bytes.
  VideoOptions o;
  o.crf = 30;
  WriteVideo(dir / "c.mp4", 80, 64, 20, o);
  EXPECT_NE(a, Slurp(dir / "c.mp4"));
}

TEST(VideoTest, ColoursSurviveTheRoundTrip) {
  TempDir dir;
  const fs::path mp4 = dir / "v.mp4";
  const int w = 64, h = 48;
  const std::vector<std::vector<unsigned char>> frames = {
      Solid(w, h, 255, 0, 0), Solid(w, h, 0, 255, 0), Solid(w, h, 0, 0, 255),
      Solid(w, h, 128, 128, 128), MakeFrame(w, h, 0)};
  {
    VideoWriter writer(mp4, w, h);
    for (const auto& f : frames) writer.AddFrame(f.data());
    writer.Finish();
  }
  std::vector<double> mean_abs_error;
  const VideoInfo info = ProbeVideo(mp4, [&](const VideoFrame& f) {
    ASSERT_EQ(f.index, static_cast<int64_t>(mean_abs_error.size()));
    ASSERT_EQ(f.width, w);
    ASSERT_EQ(f.height, h);
    const auto& want = frames.at(static_cast<size_t>(f.index));
    double sum = 0;
    for (size_t i = 0; i < want.size(); ++i) sum += std::abs(int(f.rgb[i]) - int(want[i]));
    mean_abs_error.push_back(sum / static_cast<double>(want.size()));
    if (f.index == 0) {  // red: the centre pixel
      const unsigned char* p = f.rgb + ((h / 2) * w + w / 2) * 3;
      EXPECT_GE(p[0], 240);
      EXPECT_LE(p[1], 15);
      EXPECT_LE(p[2], 15);
    }
  });
  EXPECT_EQ(info.frames, 5);
  ASSERT_EQ(mean_abs_error.size(), 5u);
  for (int i = 0; i < 4; ++i) EXPECT_LT(mean_abs_error[i], 6.0) << "solid frame " << i;
  EXPECT_LT(mean_abs_error[4], 12.0) << "textured frame";
}

TEST(VideoTest, SizeIsRoundedUpToMultiplesOf16) {
  TempDir dir;
  const fs::path mp4 = dir / "v.mp4";
  const auto red = Solid(33, 17, 255, 0, 0);
  VideoWriter writer(mp4, 33, 17);
  EXPECT_EQ(writer.encoded_width(), 48);
  EXPECT_EQ(writer.encoded_height(), 32);
  writer.AddFrame(red.data());
  writer.AddFrame(red.data());
  writer.Finish();
  int seen = 0;
  const VideoInfo info = ProbeVideo(mp4, [&](const VideoFrame& f) {
    ++seen;
    ASSERT_EQ(f.width, 48);
    ASSERT_EQ(f.height, 32);
    const unsigned char* p = f.rgb + (16 * 48 + 24) * 3;  // stretched, still red everywhere
    EXPECT_GE(p[0], 240);
    EXPECT_LE(p[1], 15);
    EXPECT_LE(p[2], 15);
  });
  EXPECT_EQ(seen, 2);
  EXPECT_EQ(info.frames, 2);
  EXPECT_EQ(info.width, 48);
  EXPECT_EQ(info.height, 32);
}

TEST(VideoTest, OtherFrameRates) {
  TempDir dir;
  VideoOptions o;
  o.fps = 30;
  o.preset = "medium";
  WriteVideo(dir / "v.mp4", 32, 32, 10, o);
  const VideoInfo info = ProbeVideo(dir / "v.mp4");
  EXPECT_EQ(info.frames, 10);
  EXPECT_NEAR(info.fps, 30.0, 1e-9);
}

TEST(VideoTest, BadSizeOrOptionsAreErrorsNamingTheFile) {
  TempDir dir;
  const fs::path mp4 = dir / "v.mp4";
  ExpectError([&] { VideoWriter(mp4, 0, 48); }, {mp4.string(), "bad video size 0x48"});
  ExpectError([&] { VideoWriter(mp4, 64, -2); }, {mp4.string(), "bad video size"});
  ExpectError([&] { VideoWriter(mp4, 16385, 16); }, {mp4.string(), "bad video size"});
  VideoOptions o;
  o.fps = 0;
  ExpectError([&] { VideoWriter(mp4, 64, 48, o); }, {mp4.string(), "fps"});
  o = {};
  o.fps = std::nan("");
  ExpectError([&] { VideoWriter(mp4, 64, 48, o); }, {mp4.string(), "fps"});
  o = {};
  o.crf = 52;
  ExpectError([&] { VideoWriter(mp4, 64, 48, o); }, {mp4.string(), "crf"});
  o = {};
  o.threads = 0;
  ExpectError([&] { VideoWriter(mp4, 64, 48, o); }, {mp4.string(), "thread"});
  o = {};
  o.preset = "warp-speed";
  ExpectError([&] { VideoWriter(mp4, 64, 48, o); },
              {mp4.string(), "unknown x264 preset \"warp-speed\""});
  EXPECT_THAT(ListFiles(dir.path()), IsEmpty());
}

TEST(VideoTest, NothingUnderTheFinalNameUntilFinish) {
  TempDir dir;
  const fs::path mp4 = dir / "v.mp4";
  const auto f = MakeFrame(32, 32, 0);
  {
    VideoWriter writer(mp4, 32, 32);
    writer.AddFrame(f.data());
    EXPECT_FALSE(fs::exists(mp4));
    const auto files = ListFiles(dir.path());
    ASSERT_EQ(files.size(), 1u);
    EXPECT_THAT(*files.begin(), HasSubstr("v.mp4.tmp."));
  }  // destroyed without Finish(): the temp file goes
  EXPECT_THAT(ListFiles(dir.path()), IsEmpty());

  VideoWriter writer(mp4, 32, 32);
  writer.AddFrame(f.data());
  VideoWriter moved = std::move(writer);
  moved.AddFrame(f.data());
  moved.Finish();
  EXPECT_EQ(ProbeVideo(mp4).frames, 2);
  ExpectError([&] { moved.AddFrame(f.data()); }, {mp4.string(), "after Finish()"});
  ExpectError([&] { moved.Finish(); }, {mp4.string(), "twice"});
  EXPECT_THAT(ListFiles(dir.path()), ElementsAre("v.mp4"));
}

TEST(VideoTest, FinishWithoutFramesIsAnError) {
  TempDir dir;
  const fs::path mp4 = dir / "sub" / "v.mp4";
  VideoWriter writer(mp4, 32, 32);
  ExpectError([&] { writer.Finish(); }, {mp4.string(), "no frames"});
  EXPECT_THAT(ListFiles(dir.path()), IsEmpty());
}

TEST(VideoTest, FinishReplacesAnExistingFile) {
  TempDir dir;
  const fs::path mp4 = dir / "v.mp4";
  WriteText(mp4, "old");
  WriteVideo(mp4, 32, 32, 3);
  EXPECT_EQ(ProbeVideo(mp4).frames, 3);
}

TEST(VideoTest, UnwritableFolderIsAnError) {
  TempDir dir;
  WriteText(dir / "file", "x");
  const fs::path mp4 = dir / "file" / "v.mp4";  // parent is a file
  ExpectError([&] { VideoWriter(mp4, 32, 32); }, {"file"});
}

TEST(VideoTest, MissingOrBrokenFilesAreErrorsNotCrashes) {
  TempDir dir;
  ExpectError([&] { ProbeVideo(dir / "missing.mp4"); }, {"missing.mp4", "file not found"});
  ExpectError([&] { ProbeVideo(dir.path()); }, {"directory"});
  WriteText(dir / "empty.mp4", "");
  ExpectError([&] { ProbeVideo(dir / "empty.mp4"); }, {"empty.mp4", "cannot open video"});
  WriteText(dir / "text.mp4", "this is not a video\n");
  ExpectError([&] { ProbeVideo(dir / "text.mp4"); }, {"text.mp4"});

  const fs::path good = dir / "good.mp4";
  WriteVideo(good, 64, 48, 64);
  const std::string bytes = Slurp(good);
  ASSERT_GT(bytes.size(), 2000u);
  // Truncated anywhere (moov is at the end, so most cuts lose it; the last cut loses frames).
  for (size_t keep :
       {size_t{8}, size_t{100}, bytes.size() / 2, bytes.size() - 200, bytes.size() - 1}) {
    const fs::path cut = dir / ("cut_" + std::to_string(keep) + ".mp4");
    WriteText(cut, std::string_view(bytes).substr(0, keep));
    ExpectError([&] { ProbeVideo(cut); }, {cut.filename().string()});
  }
  // Only the last byte missing: every frame still decodes, the box walk notices.
  ExpectError([&] { ProbeVideo(dir / ("cut_" + std::to_string(bytes.size() - 1) + ".mp4")); },
              {"truncated MP4: box 'moov'"});
  // Frame data overwritten with garbage: the decoder reports it instead of concealing it.
  std::string garbage = bytes;
  uint32_t state = 1;
  for (size_t i = garbage.size() / 4; i < garbage.size() / 2; ++i) {
    state = state * 1664525u + 1013904223u;
    garbage[i] = static_cast<char>(state >> 24);
  }
  WriteText(dir / "garbage.mp4", garbage);
  ExpectError([&] { ProbeVideo(dir / "garbage.mp4"); }, {"garbage.mp4", "corrupt video"});
}

TEST(VideoTest, RandomDamageGivesAnErrorOrAVideoNeverACrash) {
  TempDir dir;
  const fs::path good = dir / "good.mp4";
  WriteVideo(good, 32, 32, 8);
  const std::string bytes = Slurp(good);
  uint32_t state = 7;
  auto next = [&] { return state = state * 1664525u + 1013904223u; };
  int errors = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::string damaged = bytes;
    const int flips = 1 + static_cast<int>(next() >> 30);
    for (int i = 0; i < flips; ++i) {
      damaged[next() % damaged.size()] ^= static_cast<char>(1 + (next() >> 25));
    }
    WriteText(dir / "d.mp4", damaged);
    try {
      const VideoInfo info = ProbeVideo(dir / "d.mp4", [](const VideoFrame&) {});
      EXPECT_GE(info.frames, 1);
    } catch (const Error& e) {
      ++errors;
      EXPECT_THAT(e.what(), HasSubstr("d.mp4"));
    }
  }
  EXPECT_GT(errors, 0);
}

TEST(VideoTest, FfprobeAgreesWhenInstalled) {
  if (std::system("command -v ffprobe >/dev/null 2>&1") != 0) GTEST_SKIP() << "no ffprobe";
  TempDir dir;
  const fs::path mp4 = dir / "v.mp4";
  WriteVideo(mp4, 64, 48, 64);
  const fs::path out = dir / "probe.txt";
  const std::string cmd =
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
      "stream=codec_name,width,height,pix_fmt,avg_frame_rate,nb_read_frames -of default=nw=1 " +
      ShellQuote(mp4.string()) + " >" + ShellQuote(out.string());
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string probe = Slurp(out);
  EXPECT_THAT(probe, HasSubstr("codec_name=h264"));
  EXPECT_THAT(probe, HasSubstr("width=64"));
  EXPECT_THAT(probe, HasSubstr("height=48"));
  EXPECT_THAT(probe, HasSubstr("pix_fmt=yuv420p"));
  EXPECT_THAT(probe, HasSubstr("avg_frame_rate=500/33"));
  EXPECT_THAT(probe, HasSubstr("nb_read_frames=64"));
}

}  // namespace
}  // namespace mlspaces::datagen
