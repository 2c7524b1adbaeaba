// Images, PNG files (libpng's simplified API), text (stb_easy_font) and labelled grids.
#include "mlspaces/sim/pictures.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"

// stb_easy_font (libstb-dev) is a header of static functions; this file uses some of them.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#include <stb/stb_easy_font.h>
#pragma GCC diagnostic pop

namespace mlspaces::sim {

namespace {

constexpr int kMargin = 4;        // pixels around and between tiles
constexpr int kLabelPadding = 3;  // pixels above and below a label
constexpr int kLineHeight = 9;    // stb_easy_font glyphs: 7 rows, 8 with a descender shift
constexpr Rgb8 kBlack{0, 0, 0};
constexpr Rgb8 kWhite{255, 255, 255};

/// `text` with every byte outside printable ASCII replaced by '?'.
std::string Printable(std::string_view text) {
  std::string s(text);
  for (char& c : s) {
    if (c < 32 || c > 126) c = '?';
  }
  return s;
}

/// `text` cut to fit `width` pixels at `scale`, ending in "..." when cut.
std::string FitText(std::string_view text, int width, int scale) {
  std::string s = Printable(text);
  if (TextSize(s, scale)[0] <= width) return s;
  while (!s.empty() && TextSize(s + "...", scale)[0] > width) s.pop_back();
  return s.empty() ? std::string() : s + "...";
}

}  // namespace

Image Image::Filled(int width, int height, Rgb8 fill) {
  if (width < 0 || height < 0) throw UsageError("image size must not be negative");
  Image image;
  image.width = width;
  image.height = height;
  image.rgb.resize(static_cast<size_t>(width) * height * 3);
  for (size_t i = 0; i < image.rgb.size(); i += 3) {
    std::memcpy(&image.rgb[i], fill.data(), 3);
  }
  return image;
}

Rgb8 Image::At(int x, int y) const {
  const size_t i = (static_cast<size_t>(y) * width + x) * 3;
  return {rgb[i], rgb[i + 1], rgb[i + 2]};
}

// ---------------------------------------------------------------------------------------------
// Files

std::string EncodePng(const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != static_cast<size_t>(image.width) * image.height * 3) {
    throw Error("cannot write an empty or malformed image as PNG");
  }
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.rgb.data(), 0, nullptr)) {
    throw Error(std::string("libpng: ") + png.message);
  }
  std::string out(size, '\0');
  if (!png_image_write_to_memory(&png, out.data(), &size, 0, image.rgb.data(), 0, nullptr)) {
    throw Error(std::string("libpng: ") + png.message);
  }
  out.resize(size);
  return out;
}

void WritePng(const std::filesystem::path& path, const Image& image) {
  std::string bytes;
  try {
    bytes = EncodePng(image);
  } catch (const Error& e) {
    throw Error(e.message(), path.string());
  }
  WriteFileAtomic(path, bytes);
}

Image ReadPng(const std::filesystem::path& path) {
  const std::string bytes = ReadFile(path);
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size())) {
    throw Error(std::string("not a readable PNG: ") + png.message, path.string());
  }
  png.format = PNG_FORMAT_RGB;
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgb.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, image.rgb.data(), 0, nullptr)) {
    png_image_free(&png);
    throw Error(std::string("not a readable PNG: ") + png.message, path.string());
  }
  return image;
}

// ---------------------------------------------------------------------------------------------
// Drawing

std::array<int, 2> TextSize(std::string_view text, int scale) {
  if (text.empty()) return {0, 0};
  std::string s = Printable(text);
  return {stb_easy_font_width(s.data()) * scale, kLineHeight * scale};
}

void FillRect(Image& image, int x, int y, int w, int h, Rgb8 color) {
  const int x0 = std::max(x, 0), y0 = std::max(y, 0);
  const int x1 = std::min(x + w, image.width), y1 = std::min(y + h, image.height);
  for (int r = y0; r < y1; ++r) {
    for (int c = x0; c < x1; ++c) {
      std::memcpy(&image.rgb[(static_cast<size_t>(r) * image.width + c) * 3], color.data(), 3);
    }
  }
}

void DrawText(Image& image, int x, int y, std::string_view text, Rgb8 color, int scale) {
  std::string s = Printable(text);
  if (s.empty()) return;
  // stb_easy_font emits quads (4 vertices of x, y, z floats + 4 colour bytes) of whole pixels.
  struct Vertex {
    float x, y, z;
    unsigned char c[4];
  };
  std::vector<Vertex> quads(s.size() * 64 * 4);
  const int n = stb_easy_font_print(0, 0, s.data(), nullptr, quads.data(),
                                    static_cast<int>(quads.size() * sizeof(Vertex)));
  for (int q = 0; q < n; ++q) {
    const Vertex* v = &quads[static_cast<size_t>(q) * 4];
    const float qx0 = std::min({v[0].x, v[1].x, v[2].x, v[3].x});
    const float qy0 = std::min({v[0].y, v[1].y, v[2].y, v[3].y});
    const float qx1 = std::max({v[0].x, v[1].x, v[2].x, v[3].x});
    const float qy1 = std::max({v[0].y, v[1].y, v[2].y, v[3].y});
    const int px = x + static_cast<int>(std::lround(qx0)) * scale;
    const int py = y + static_cast<int>(std::lround(qy0)) * scale;
    FillRect(image, px, py, static_cast<int>(std::lround(qx1 - qx0)) * scale,
             static_cast<int>(std::lround(qy1 - qy0)) * scale, color);
  }
}

namespace {

struct GridLayout {
  int columns = 0, scale = 1, label_h = 0, title_h = 0, width = 0, height = 0;
};

GridLayout Layout(size_t n, int tw, int th, int columns, bool titled) {
  if (n < 1) throw UsageError("a grid needs at least one tile");
  if (tw < 1 || th < 1) {
    throw UsageError("grid tiles of " + std::to_string(tw) + "x" + std::to_string(th) +
                     " pixels: both sides must be positive");
  }
  GridLayout g;
  const uint64_t cols = columns > 0
                            ? std::min<uint64_t>(columns, n)
                            : static_cast<uint64_t>(std::ceil(std::sqrt(static_cast<double>(n))));
  const uint64_t rows = (n + cols - 1) / cols;
  g.scale = tw >= 200 ? 2 : 1;
  g.label_h = kLineHeight * g.scale + 2 * kLabelPadding;
  g.title_h = titled ? kLineHeight * 2 + 2 * kLabelPadding + kMargin : 0;
  const uint64_t width = cols * (tw + kMargin) + kMargin;
  const uint64_t height = g.title_h + rows * (th + g.label_h + kMargin) + kMargin;
  if (width > kMaxGridSide || height > kMaxGridSide) {
    throw UsageError(std::to_string(n) + " tiles of " + std::to_string(tw) + "x" +
                     std::to_string(th) + " in " + std::to_string(cols) + " columns make a " +
                     std::to_string(width) + "x" + std::to_string(height) + " picture, over the " +
                     std::to_string(kMaxGridSide) +
                     " pixels a side it may have: fewer or smaller tiles, or other columns");
  }
  g.columns = static_cast<int>(cols);  // at most kMaxGridSide now
  g.width = static_cast<int>(width);
  g.height = static_cast<int>(height);
  return g;
}

}  // namespace

std::array<int, 2> GridSize(size_t n, int tile_width, int tile_height, int columns, bool titled) {
  const GridLayout g = Layout(n, tile_width, tile_height, columns, titled);
  return {g.width, g.height};
}

Image ComposeGrid(const std::vector<Image>& tiles, const std::vector<std::string>& labels,
                  int columns, std::string_view title) {
  if (tiles.empty()) throw UsageError("a grid needs at least one tile");
  if (labels.size() != tiles.size()) {
    throw UsageError("a grid needs one label per tile (" + std::to_string(tiles.size()) +
                     " tiles, " + std::to_string(labels.size()) + " labels)");
  }
  const int tw = tiles[0].width, th = tiles[0].height;
  for (const Image& t : tiles) {
    if (t.width != tw || t.height != th) throw UsageError("grid tiles differ in size");
  }
  const GridLayout g = Layout(tiles.size(), tw, th, columns, !title.empty());
  const int n = static_cast<int>(tiles.size());
  columns = g.columns;
  const int scale = g.scale, label_h = g.label_h, title_h = g.title_h, width = g.width;
  Image out = Image::Filled(width, g.height, kWhite);
  if (!title.empty()) {
    const int ts = TextSize(title, 2)[0] <= width - 2 * kMargin ? 2 : 1;
    const std::string t = FitText(title, width - 2 * kMargin, ts);
    DrawText(out, kMargin, kMargin + kLabelPadding, t, kBlack, ts);
  }
  for (int i = 0; i < n; ++i) {
    const int x = kMargin + (i % columns) * (tw + kMargin);
    const int y = title_h + kMargin + (i / columns) * (th + label_h + kMargin);
    for (int r = 0; r < th; ++r) {
      std::memcpy(&out.rgb[(static_cast<size_t>(y + r) * width + x) * 3],
                  &tiles[i].rgb[static_cast<size_t>(r) * tw * 3], static_cast<size_t>(tw) * 3);
    }
    int s = scale;
    if (s > 1 && TextSize(labels[i], s)[0] > tw) s = 1;
    const std::string label = FitText(labels[i], tw, s);
    DrawText(out, x, y + th + kLabelPadding, label, kBlack, s);
  }
  return out;
}

}  // namespace mlspaces::sim
