#include "av1_writer.h"

#include <cstdlib>
#include <string>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

#include "av_util.h"
#include "mlspaces/core/error.h"

namespace mlspaces::datagen::lerobot {
namespace fs = std::filesystem;

namespace {}  // namespace

struct Av1Writer::Impl {
  fs::path path;
  int width = 0, height = 0;
  AVCodecContext* enc = nullptr;
  AVFormatContext* mux = nullptr;
  AVStream* stream = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* pkt = nullptr;
  SwsContext* sws = nullptr;
  int64_t next_pts = 0;

  ~Impl() {
    sws_freeContext(sws);
    av_packet_free(&pkt);
    av_frame_free(&frame);
    avcodec_free_context(&enc);
    if (mux != nullptr) {
      if (mux->pb != nullptr) avio_closep(&mux->pb);
      avformat_free_context(mux);
    }
  }

  void Fail(const std::string& what, int ret) const {
    throw Error(what + (ret < 0 ? ": " + AvError(ret) : std::string()), path.string());
  }

  // Sends `f` (nullptr: flush) and writes every packet the encoder hands back.
  void Encode(AVFrame* f) {
    int ret = avcodec_send_frame(enc, f);
    if (ret < 0) Fail("AV1 encoding failed", ret);
    while ((ret = avcodec_receive_packet(enc, pkt)) >= 0) {
      av_packet_rescale_ts(pkt, enc->time_base, stream->time_base);
      pkt->stream_index = stream->index;
      if ((ret = av_interleaved_write_frame(mux, pkt)) < 0) Fail("cannot write a packet", ret);
    }
    if (ret != AVERROR(EAGAIN) && ret != AVERROR_EOF) Fail("AV1 encoding failed", ret);
  }
};

Av1Writer::Av1Writer(fs::path path, int width, int height, double fps) : impl_(new Impl) {
  Impl& m = *impl_;
  m.path = std::move(path);
  m.width = width;
  m.height = height;
  // SVT-AV1 prints its configuration on stderr unless told to log errors only.
  setenv("SVT_LOG", "1", /*overwrite=*/0);
  // SVT-AV1 needs frames of at least 64x64; libaom takes any size.
  const AVCodec* codec =
      width >= 64 && height >= 64 ? avcodec_find_encoder_by_name("libsvtav1") : nullptr;
  if (codec == nullptr) codec = avcodec_find_encoder_by_name("libaom-av1");
  if (codec == nullptr) m.Fail("this FFmpeg has no AV1 encoder (libsvtav1 or libaom-av1)", 0);
  m.enc = avcodec_alloc_context3(codec);
  if (m.enc == nullptr) m.Fail("cannot allocate the AV1 encoder", 0);
  const AVRational rate = av_d2q(fps, 100000);
  m.enc->width = width;
  m.enc->height = height;
  m.enc->pix_fmt = AV_PIX_FMT_YUV420P;
  m.enc->time_base = av_inv_q(rate);
  m.enc->framerate = rate;
  m.enc->gop_size = 2;
  m.enc->color_range = AVCOL_RANGE_MPEG;
  m.enc->colorspace = AVCOL_SPC_BT470BG;
  m.enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
  av_opt_set_int(m.enc->priv_data, "crf", 30, 0);
  av_opt_set_int(m.enc->priv_data, "preset", 8, 0);    // SVT-AV1's speed
  av_opt_set_int(m.enc->priv_data, "cpu-used", 8, 0);  // libaom's
  int ret = avcodec_open2(m.enc, codec, nullptr);
  if (ret < 0) m.Fail("cannot open the AV1 encoder", ret);
  if ((ret = avformat_alloc_output_context2(&m.mux, nullptr, "mp4", m.path.c_str())) < 0) {
    m.Fail("cannot create an MP4 muxer", ret);
  }
  m.mux->flags |= AVFMT_FLAG_BITEXACT;
  m.stream = avformat_new_stream(m.mux, nullptr);
  if (m.stream == nullptr) m.Fail("cannot add a video stream", 0);
  avcodec_parameters_from_context(m.stream->codecpar, m.enc);
  m.stream->time_base = m.enc->time_base;
  m.stream->avg_frame_rate = rate;
  if ((ret = avio_open(&m.mux->pb, m.path.c_str(), AVIO_FLAG_WRITE)) < 0) {
    m.Fail("cannot create the file", ret);
  }
  if ((ret = avformat_write_header(m.mux, nullptr)) < 0) m.Fail("cannot write the MP4 header", ret);
  m.frame = av_frame_alloc();
  m.pkt = av_packet_alloc();
  m.frame->format = AV_PIX_FMT_YUV420P;
  m.frame->width = width;
  m.frame->height = height;
  if (m.frame == nullptr || m.pkt == nullptr || av_frame_get_buffer(m.frame, 0) < 0) {
    m.Fail("cannot allocate a frame", 0);
  }
  m.sws = sws_getContext(width, height, AV_PIX_FMT_RGB24, width, height, AV_PIX_FMT_YUV420P,
                         SWS_BICUBIC, nullptr, nullptr, nullptr);
  if (m.sws == nullptr) m.Fail("cannot convert RGB to YUV", 0);
}

Av1Writer::~Av1Writer() = default;

void Av1Writer::AddFrame(const unsigned char* rgb) {
  Impl& m = *impl_;
  int ret = av_frame_make_writable(m.frame);
  if (ret < 0) m.Fail("cannot write a frame", ret);
  const uint8_t* src[4] = {rgb, nullptr, nullptr, nullptr};
  const int src_stride[4] = {3 * m.width, 0, 0, 0};
  sws_scale(m.sws, src, src_stride, 0, m.height, m.frame->data, m.frame->linesize);
  m.frame->pts = m.next_pts++;
  m.Encode(m.frame);
}

void Av1Writer::Finish() {
  Impl& m = *impl_;
  m.Encode(nullptr);
  int ret = av_write_trailer(m.mux);
  if (ret < 0) m.Fail("cannot finish the MP4", ret);
  if ((ret = avio_closep(&m.mux->pb)) < 0) m.Fail("cannot close the file", ret);
}

}  // namespace mlspaces::datagen::lerobot
