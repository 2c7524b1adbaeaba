// mlspaces render {assets,grasps,scene,episode}: PNG pictures through the headless renderer
// (docs/render.md). This file holds the shared flags; each command is render_<command>.cc.
#include "render.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <string>
#include <string_view>
#include <system_error>

#include "mlspaces/core/error.h"
#include "mlspaces/core/strings.h"

namespace mlspaces::cli {

void RenderFlags::AddTo(CLI::App& app, const std::string& default_size) {
  size = default_size;
  app.add_option("--out,-o", out, "The PNG to write")->required()->type_name("FILE.png");
  app.add_option("--size", size, "Size of each picture in pixels (default " + default_size + ")")
      ->type_name("WxH");
  app.add_option("--gl", gl, "Headless GL: osmesa (default) or egl; default from MLSPACES_GL")
      ->type_name("osmesa|egl");
  app.add_option("--columns", columns, "Pictures per row (default: about square)")
      ->check(PositiveInteger());
  app.add_flag("-q,--quiet", quiet, "No progress lines");
}

sim::PictureOptions RenderFlags::Options() const {
  sim::PictureOptions o;
  // Two whole numbers around 'x', nothing else: no space, '+' or suffix, and no number past
  // int (sscanf wrapped "4294967328" around to 32); a negative one is below 8.
  int w = 0, h = 0;
  auto number = [](std::string_view text, int* out) {
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), *out);
    return !text.empty() && ec == std::errc() && end == text.data() + text.size();
  };
  const size_t x = size.find('x');
  if (x == std::string::npos || !number(std::string_view(size).substr(0, x), &w) ||
      !number(std::string_view(size).substr(x + 1), &h) || std::min(w, h) < sim::kMinPictureSide ||
      std::max(w, h) > sim::kMaxPictureSide) {
    throw UsageError("--size: expected WxH with each in [" + std::to_string(sim::kMinPictureSide) +
                     ", " + std::to_string(sim::kMaxPictureSide) + "], got '" + size + "'");
  }
  o.width = w;
  o.height = h;
  o.backend = sim::ResolveGlBackend(gl, "--gl");
  return o;
}

void RenderFlags::Progress(const std::string& text) const {
  if (!quiet) std::fprintf(stderr, "render: %s\n", Printable(text).c_str());
}

void RenderFlags::Write(const sim::Image& image) const {
  sim::WritePng(out, image);
  std::printf("wrote %s (%d x %d)\n", out.c_str(), image.width, image.height);
}

void AddRender(CLI::App& app, Action& action) {
  CLI::App* sub = app.add_subcommand(
      "render", "Pictures as PNG: a library's assets, an asset's grasps, a scene, an episode");
  sub->require_subcommand(1);
  AddRenderAssets(*sub, action);
  AddRenderGrasps(*sub, action);
  AddRenderScene(*sub, action);
  AddRenderEpisode(*sub, action);
}

}  // namespace mlspaces::cli
