// `mlspaces render`: the flags its commands share, and one Add* per command
// (render_<command>.cc); render.cc registers them under `render`.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "mlspaces/sim/pictures.h"

namespace mlspaces::cli {

/// --out FILE.png, --size WxH (each tile), --gl osmesa|egl, --columns N, -q.
struct RenderFlags {
  std::string out;
  std::string size;
  std::string gl;
  int columns = 0;
  bool quiet = false;

  /// Adds the flags; `default_size` is the --size default ("256x256").
  void AddTo(CLI::App& app, const std::string& default_size);
  /// The tile size and GL of the flags (gl: --gl, else MLSPACES_GL, else osmesa).
  /// @throws UsageError for a malformed --size or an unknown --gl.
  sim::PictureOptions Options() const;
  /// Prints "render: <text>" to stderr unless -q.
  void Progress(const std::string& text) const;
  /// Writes the image to --out and prints "wrote FILE (W x H)".
  void Write(const sim::Image& image) const;
};

void AddRenderAssets(CLI::App& render, Action& action);
void AddRenderGrasps(CLI::App& render, Action& action);
void AddRenderScene(CLI::App& render, Action& action);
void AddRenderEpisode(CLI::App& render, Action& action);

}  // namespace mlspaces::cli
