#include "mlspaces/datagen/video.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstring>
#include <fstream>
#include <iterator>
#include <mutex>
#include <string_view>
#include <utility>
#include <vector>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/imgutils.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

#include "mlspaces/core/crash_point.h"
#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

namespace mlspaces::datagen {
namespace fs = std::filesystem;

namespace {

constexpr int kMaxSide = 16384;
constexpr std::string_view kPresets[] = {"ultrafast", "superfast", "veryfast", "faster",
                                         "fast",      "medium",    "slow",     "slower",
                                         "veryslow",  "placebo"};
// Bicubic as ffmpeg's scale filter (what imageio used); bit-exact, accurately rounded C paths so
// the bytes do not depend on the CPU's SIMD.
constexpr int kSwsFlags = SWS_BICUBIC | SWS_ACCURATE_RND | SWS_BITEXACT;

// FFmpeg logs go nowhere (nothing is printed on success); the last error-level line of the
// calling thread is kept and put into our Error messages.
thread_local std::string t_last_av_error;

void AvLogCallback(void* avcl, int level, const char* fmt, va_list vl) {
  if (level > AV_LOG_ERROR) return;
  char line[1024];
  int print_prefix = 0;  // no "[name @ 0xADDRESS]": the name is added below, the address never
  av_log_format_line2(avcl, level, fmt, vl, line, sizeof line, &print_prefix);
  std::string_view s(line);
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) {
    s.remove_suffix(1);
  }
  if (s.empty()) return;
  const AVClass* cls = avcl != nullptr ? *static_cast<const AVClass* const*>(avcl) : nullptr;
  const char* name = cls != nullptr && cls->item_name != nullptr ? cls->item_name(avcl) : nullptr;
  t_last_av_error = name != nullptr ? std::string(name) + ": " + std::string(s) : std::string(s);
}

void InitAvLogging() {
  static std::once_flag once;
  std::call_once(once, [] { av_log_set_callback(AvLogCallback); });
}

/// "what: <av_strerror>" plus FFmpeg's last logged error line, if any since the last call.
std::string AvMessage(const std::string& what, int err) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(err, buf, sizeof buf);
  std::string out = what + ": " + buf;
  if (!t_last_av_error.empty()) out += " (" + t_last_av_error + ")";
  t_last_av_error.clear();
  return out;
}

int RoundUp16(int v) { return (v + 15) / 16 * 16; }

struct PacketDeleter {
  void operator()(AVPacket* p) const { av_packet_free(&p); }
};
struct FrameDeleter {
  void operator()(AVFrame* f) const { av_frame_free(&f); }
};
struct CodecDeleter {
  void operator()(AVCodecContext* c) const { avcodec_free_context(&c); }
};
struct SwsDeleter {
  void operator()(SwsContext* s) const { sws_freeContext(s); }
};
struct InputDeleter {
  void operator()(AVFormatContext* f) const { avformat_close_input(&f); }
};
struct DictDeleter {
  void operator()(AVDictionary* d) const { av_dict_free(&d); }
};

/// For an MP4/MOV file: the top-level boxes must tile the file exactly. The demuxer forgives a
/// box cut short at the end (a file missing its last bytes can still decode), this does not.
/// Returns "" or what is wrong.
std::string CheckTopLevelBoxes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const uint64_t file_size = fs::file_size(path, ec);
  if (!in || ec) return "cannot read";
  uint64_t off = 0;
  while (off < file_size) {
    unsigned char h[16];
    const uint64_t left = file_size - off;
    if (left < 8) return "truncated MP4: " + std::to_string(left) + " stray bytes at the end";
    in.seekg(static_cast<std::streamoff>(off));
    if (!in.read(reinterpret_cast<char*>(h), 8)) return "cannot read";
    uint64_t size = (uint64_t{h[0]} << 24) | (uint64_t{h[1]} << 16) | (uint64_t{h[2]} << 8) | h[3];
    uint64_t header = 8;
    if (size == 1) {
      if (left < 16 || !in.read(reinterpret_cast<char*>(h + 8), 8)) {
        return "truncated MP4: box header at offset " + std::to_string(off);
      }
      size = 0;
      for (int i = 8; i < 16; ++i) size = (size << 8) | h[i];
      header = 16;
    } else if (size == 0) {
      size = left;  // "to the end of the file"
    }
    const std::string type(reinterpret_cast<const char*>(h + 4), 4);
    if (size < header) return "corrupt MP4: box '" + type + "' at offset " + std::to_string(off);
    if (size > left) {
      return "truncated MP4: box '" + type + "' at offset " + std::to_string(off) + " needs " +
             std::to_string(size) + " bytes, the file has " + std::to_string(left);
    }
    off += size;
  }
  return "";
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// VideoWriter

struct VideoWriter::Impl {
  fs::path path, tmp;
  int width = 0, height = 0, enc_width = 0, enc_height = 0;
  VideoOptions options;
  AVFormatContext* fmt = nullptr;  // output; pb closed in CloseOutput()
  AVStream* stream = nullptr;
  std::unique_ptr<AVCodecContext, CodecDeleter> enc;
  std::unique_ptr<SwsContext, SwsDeleter> sws;
  std::unique_ptr<AVFrame, FrameDeleter> frame;
  std::unique_ptr<AVPacket, PacketDeleter> pkt;
  int64_t frames = 0;
  bool finished = false;
  bool failed = false;

  ~Impl() {
    CloseOutput();
    if (!finished && !tmp.empty()) {
      std::error_code ec;
      fs::remove(tmp, ec);
    }
  }

  /// Closes the file (if open) and frees the muxer; returns avio_closep's result.
  int CloseOutput() {
    int ret = 0;
    if (fmt != nullptr) {
      if (fmt->pb != nullptr) ret = avio_closep(&fmt->pb);
      avformat_free_context(fmt);
      fmt = nullptr;
      stream = nullptr;
    }
    return ret;
  }

  [[noreturn]] void Fail(const std::string& message) {
    failed = true;
    throw Error(message, path.string());
  }

  /// Moves every packet the encoder has ready into the muxer.
  void DrainPackets() {
    for (;;) {
      int ret = avcodec_receive_packet(enc.get(), pkt.get());
      if (ret == AVERROR(EAGAIN) || ret == AVERROR_EOF) return;
      if (ret < 0) Fail(AvMessage("H.264 encoding failed", ret));
      if (pkt->duration == 0) pkt->duration = 1;  // one frame, in the encoder's time base
      av_packet_rescale_ts(pkt.get(), enc->time_base, stream->time_base);
      pkt->stream_index = stream->index;
      ret = av_interleaved_write_frame(fmt, pkt.get());  // takes the packet's reference
      if (ret < 0) Fail(AvMessage("cannot write video", ret));
    }
  }
};

VideoWriter::VideoWriter(fs::path path, int width, int height, VideoOptions options)
    : impl_(std::make_unique<Impl>()) {
  InitAvLogging();
  t_last_av_error.clear();
  Impl& m = *impl_;
  m.path = std::move(path);
  m.width = width;
  m.height = height;
  m.options = std::move(options);
  const std::string where = m.path.string();
  if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide) {
    throw Error("bad video size " + std::to_string(width) + "x" + std::to_string(height) +
                    " (each side must be 1-" + std::to_string(kMaxSide) + ")",
                where);
  }
  const VideoOptions& o = m.options;
  if (!std::isfinite(o.fps) || o.fps <= 0 || o.fps > 1000) {
    throw Error("bad video fps " + std::to_string(o.fps) + " (must be in (0, 1000])", where);
  }
  if (o.crf < 0 || o.crf > 51) {
    throw Error("bad video crf " + std::to_string(o.crf) + " (must be 0-51)", where);
  }
  if (o.threads < 1 || o.threads > 64) {
    throw Error("bad video thread count " + std::to_string(o.threads) + " (must be 1-64)", where);
  }
  // Checked here: x264 itself would print an unknown preset to stderr.
  if (std::find(std::begin(kPresets), std::end(kPresets), o.preset) == std::end(kPresets)) {
    throw Error("unknown x264 preset \"" + o.preset +
                    "\" (ultrafast, superfast, veryfast, faster, fast, medium, slow, slower, "
                    "veryslow, placebo)",
                where);
  }
  m.enc_width = RoundUp16(width);
  m.enc_height = RoundUp16(height);

  const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
  if (codec == nullptr) throw Error("this FFmpeg has no libx264 encoder", where);
  m.enc.reset(avcodec_alloc_context3(codec));
  m.frame.reset(av_frame_alloc());
  m.pkt.reset(av_packet_alloc());
  if (!m.enc || !m.frame || !m.pkt) throw Error("out of memory opening the encoder", where);

  const AVRational fps = av_d2q(o.fps, 100000);
  AVCodecContext* c = m.enc.get();
  c->width = m.enc_width;
  c->height = m.enc_height;
  c->pix_fmt = AV_PIX_FMT_YUV420P;
  c->time_base = av_inv_q(fps);
  c->framerate = fps;
  c->sample_aspect_ratio = AVRational{1, 1};
  c->thread_count = o.threads;
  c->flags |= AV_CODEC_FLAG_BITEXACT | AV_CODEC_FLAG_GLOBAL_HEADER;  // mp4 wants avcC
  c->color_range = AVCOL_RANGE_MPEG;
  c->colorspace = AVCOL_SPC_SMPTE170M;  // BT.601, what swscale converts with
  AVDictionary* raw_opts = nullptr;
  av_dict_set(&raw_opts, "preset", o.preset.c_str(), 0);
  av_dict_set(&raw_opts, "crf", std::to_string(o.crf).c_str(), 0);
  // x264's macroblock tree makes the bytes depend on what the process encoded before (the
  // same frames gave other bytes after other videos; tests/datagen/episode_runner_test.cc
  // CameraVideosDependOnlyOnTheEpisode). Without it the output is a function of the frames,
  // for files a few percent larger.
  // A camera's video is one shot under constant lights: no scene cuts to look for, no fades
  // for weighted prediction, and B-frames in x264's fixed pattern rather than chosen by its
  // lookahead. On the tutorial's videos that is a quarter less encoding time for files 1%
  // smaller at the same SSIM, at veryfast and at medium (docs/datagen.md).
  av_dict_set(&raw_opts, "x264-params", "mbtree=0:scenecut=0:weightp=0:b-adapt=0", 0);
  int ret = avcodec_open2(c, codec, &raw_opts);
  std::unique_ptr<AVDictionary, DictDeleter> opts(raw_opts);
  if (ret < 0) {
    throw Error(AvMessage("cannot open the H.264 encoder (preset \"" + o.preset + "\")", ret),
                where);
  }

  m.frame->format = AV_PIX_FMT_YUV420P;
  m.frame->width = m.enc_width;
  m.frame->height = m.enc_height;
  if ((ret = av_frame_get_buffer(m.frame.get(), 0)) < 0) {
    throw Error(AvMessage("cannot allocate a video frame", ret), where);
  }
  m.sws.reset(sws_getContext(width, height, AV_PIX_FMT_RGB24, m.enc_width, m.enc_height,
                             AV_PIX_FMT_YUV420P, kSwsFlags, nullptr, nullptr, nullptr));
  if (!m.sws) throw Error("cannot create the RGB to YUV converter", where);

  // The muxer, on a temp file beside the target.
  std::error_code ec;
  const fs::path parent = m.path.parent_path();
  if (!parent.empty()) {
    fs::create_directories(parent, ec);
    if (ec) throw Error("cannot create folder: " + ec.message(), parent.string());
  }
  m.tmp = fs::path(m.path.string() + TempSuffix());
  ret = avformat_alloc_output_context2(&m.fmt, nullptr, "mp4", m.tmp.c_str());
  if (ret < 0 || m.fmt == nullptr) {
    throw Error(AvMessage("cannot create the MP4 muxer", ret), where);
  }
  m.fmt->flags |= AVFMT_FLAG_BITEXACT;  // no library version; no creation time is set
  m.stream = avformat_new_stream(m.fmt, nullptr);
  if (m.stream == nullptr) throw Error("cannot create the video stream", where);
  m.stream->time_base = c->time_base;
  m.stream->avg_frame_rate = fps;
  if ((ret = avcodec_parameters_from_context(m.stream->codecpar, c)) < 0) {
    throw Error(AvMessage("cannot set the stream parameters", ret), where);
  }
  if ((ret = avio_open(&m.fmt->pb, m.tmp.c_str(), AVIO_FLAG_WRITE)) < 0) {
    m.tmp.clear();  // nothing was created
    throw Error(AvMessage("cannot write", ret), where);
  }
  if ((ret = avformat_write_header(m.fmt, nullptr)) < 0) {
    throw Error(AvMessage("cannot write the MP4 header", ret), where);
  }
}

VideoWriter::~VideoWriter() = default;
VideoWriter::VideoWriter(VideoWriter&&) noexcept = default;
VideoWriter& VideoWriter::operator=(VideoWriter&&) noexcept = default;

void VideoWriter::AddFrame(const unsigned char* rgb) {
  Impl& m = *impl_;
  if (m.finished) throw Error("frame added after Finish()", m.path.string());
  if (m.failed) throw Error("frame added after a failed write", m.path.string());
  if (rgb == nullptr) throw Error("null frame", m.path.string());
  t_last_av_error.clear();
  int ret = av_frame_make_writable(m.frame.get());
  if (ret < 0) m.Fail(AvMessage("cannot allocate a video frame", ret));
  const uint8_t* src[1] = {rgb};
  const int src_stride[1] = {3 * m.width};
  sws_scale(m.sws.get(), src, src_stride, 0, m.height, m.frame->data, m.frame->linesize);
  m.frame->pts = m.frames;
  ret = avcodec_send_frame(m.enc.get(), m.frame.get());
  if (ret < 0) m.Fail(AvMessage("H.264 encoding failed", ret));
  ++m.frames;
  m.DrainPackets();
}

void VideoWriter::Finish() {
  Impl& m = *impl_;
  const std::string where = m.path.string();
  if (m.finished) throw Error("Finish() called twice", where);
  if (m.failed) throw Error("Finish() after a failed write", where);
  t_last_av_error.clear();
  try {
    if (m.frames == 0) throw Error("no frames to write", where);
    int ret = avcodec_send_frame(m.enc.get(), nullptr);  // flush (B-frames, lookahead)
    if (ret < 0) m.Fail(AvMessage("H.264 encoding failed", ret));
    m.DrainPackets();
    if ((ret = av_write_trailer(m.fmt)) < 0) m.Fail(AvMessage("cannot write the MP4 trailer", ret));
    if ((ret = m.CloseOutput()) < 0) m.Fail(AvMessage("cannot write video", ret));
    FsyncPath(m.tmp, false, where);
    if (::rename(m.tmp.c_str(), m.path.c_str()) != 0) {
      m.Fail(std::string("cannot rename into place: ") + std::strerror(errno));
    }
  } catch (...) {
    m.failed = true;
    m.CloseOutput();
    std::error_code ec;
    fs::remove(m.tmp, ec);
    m.tmp.clear();
    throw;
  }
  m.finished = true;
  m.enc.reset();
  m.sws.reset();
  m.frame.reset();
  m.pkt.reset();
  const fs::path parent = m.path.parent_path().empty() ? fs::path(".") : m.path.parent_path();
  FsyncPath(parent, true, parent.string());
  CrashPoint("video renamed into place");
}

int64_t VideoWriter::frames() const { return impl_->frames; }
int VideoWriter::encoded_width() const { return impl_->enc_width; }
int VideoWriter::encoded_height() const { return impl_->enc_height; }
const fs::path& VideoWriter::path() const { return impl_->path; }

// ---------------------------------------------------------------------------------------------
// ProbeVideo

VideoInfo ProbeVideo(const fs::path& path, const VideoFrameCallback& on_frame) {
  InitAvLogging();
  t_last_av_error.clear();
  const std::string where = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("file not found", where);
  if (fs::is_directory(path, ec)) throw Error("is a directory, expected a video file", where);

  AVFormatContext* raw_fmt = nullptr;
  int ret = avformat_open_input(&raw_fmt, path.c_str(), nullptr, nullptr);
  if (ret < 0) throw Error(AvMessage("cannot open video", ret), where);
  std::unique_ptr<AVFormatContext, InputDeleter> fmt(raw_fmt);
  if (std::string_view(fmt->iformat->name).find("mp4") != std::string_view::npos) {
    if (std::string problem = CheckTopLevelBoxes(path); !problem.empty()) {
      throw Error(problem, where);
    }
  }
  if ((ret = avformat_find_stream_info(fmt.get(), nullptr)) < 0) {
    throw Error(AvMessage("cannot read video stream info", ret), where);
  }
  const AVCodec* codec = nullptr;
  const int index = av_find_best_stream(fmt.get(), AVMEDIA_TYPE_VIDEO, -1, -1, &codec, 0);
  if (index < 0 || codec == nullptr) {
    throw Error(
        index == AVERROR_DECODER_NOT_FOUND ? "no decoder for the video stream" : "no video stream",
        where);
  }
  const AVStream* st = fmt->streams[index];
  std::unique_ptr<AVCodecContext, CodecDeleter> dec(avcodec_alloc_context3(codec));
  if (!dec) throw Error("out of memory opening the decoder", where);
  if ((ret = avcodec_parameters_to_context(dec.get(), st->codecpar)) < 0) {
    throw Error(AvMessage("bad video stream parameters", ret), where);
  }
  dec->thread_count = 1;
  dec->err_recognition |= AV_EF_EXPLODE;  // report damage instead of concealing it
  if ((ret = avcodec_open2(dec.get(), codec, nullptr)) < 0) {
    throw Error(AvMessage("cannot open the video decoder", ret), where);
  }

  VideoInfo info;
  info.codec = codec->name;
  info.width = dec->width;
  info.height = dec->height;
  AVRational rate = st->avg_frame_rate;
  if (rate.num <= 0 || rate.den <= 0) rate = st->r_frame_rate;
  if (rate.num > 0 && rate.den > 0) info.fps = av_q2d(rate);

  std::unique_ptr<AVPacket, PacketDeleter> pkt(av_packet_alloc());
  std::unique_ptr<AVFrame, FrameDeleter> frame(av_frame_alloc());
  if (!pkt || !frame) throw Error("out of memory decoding", where);
  std::unique_ptr<SwsContext, SwsDeleter> sws;
  std::vector<unsigned char> rgb;

  auto receive = [&] {
    for (;;) {
      int r = avcodec_receive_frame(dec.get(), frame.get());
      if (r == AVERROR(EAGAIN) || r == AVERROR_EOF) return;
      if (r < 0) throw Error(AvMessage("corrupt video", r), where);
      if (frame->decode_error_flags != 0 || (frame->flags & AV_FRAME_FLAG_CORRUPT) != 0) {
        throw Error("corrupt video: frame " + std::to_string(info.frames) + " decoded with errors",
                    where);
      }
      if (info.frames == 0) {
        info.width = frame->width;
        info.height = frame->height;
      }
      if (on_frame) {
        const int w = frame->width, h = frame->height;
        sws.reset(sws_getCachedContext(sws.release(), w, h,
                                       static_cast<AVPixelFormat>(frame->format), w, h,
                                       AV_PIX_FMT_RGB24, kSwsFlags, nullptr, nullptr, nullptr));
        if (!sws) throw Error("cannot convert the video's pixel format to RGB", where);
        const int* coeffs = sws_getCoefficients(
            frame->colorspace == AVCOL_SPC_BT709 ? SWS_CS_ITU709 : SWS_CS_DEFAULT);
        sws_setColorspaceDetails(sws.get(), coeffs, frame->color_range == AVCOL_RANGE_JPEG,
                                 sws_getCoefficients(SWS_CS_DEFAULT), 1, 0, 1 << 16, 1 << 16);
        rgb.resize(static_cast<size_t>(w) * h * 3);
        uint8_t* dst[1] = {rgb.data()};
        const int dst_stride[1] = {3 * w};
        sws_scale(sws.get(), frame->data, frame->linesize, 0, h, dst, dst_stride);
        on_frame(VideoFrame{info.frames, w, h, rgb.data()});
      }
      ++info.frames;
      av_frame_unref(frame.get());
    }
  };

  for (;;) {
    ret = av_read_frame(fmt.get(), pkt.get());
    if (ret == AVERROR_EOF) break;
    if (ret < 0) throw Error(AvMessage("cannot read video", ret), where);
    if (pkt->stream_index != index) {
      av_packet_unref(pkt.get());
      continue;
    }
    ret = avcodec_send_packet(dec.get(), pkt.get());
    av_packet_unref(pkt.get());
    if (ret < 0) throw Error(AvMessage("corrupt video", ret), where);
    receive();
  }
  if ((ret = avcodec_send_packet(dec.get(), nullptr)) < 0) {
    throw Error(AvMessage("corrupt video", ret), where);
  }
  receive();
  if (info.frames == 0) throw Error("no frames decoded", where);
  if (st->nb_frames > 0 && info.frames < st->nb_frames) {
    throw Error("corrupt video: decoded " + std::to_string(info.frames) + " of " +
                    std::to_string(st->nb_frames) + " frames",
                where);
  }
  return info;
}

}  // namespace mlspaces::datagen
