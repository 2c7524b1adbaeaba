// Pictures of libraries and models (`mlspaces render`, mlspaces.render): RGB images in memory,
// PNG files, text drawn into images, labelled grids, and headless renderings (sim::Renderer)
// of an asset alone, of an asset with its grasps drawn as gripper outlines, and of any model
// from several views.
//
// Images are 8-bit RGB, rows top to bottom. Text is stb_easy_font's (libstb-dev, public
// domain): ASCII only, drawn as filled rectangles, so it needs no font file at run time and
// gives the same pixels everywhere.
#pragma once

#include "mlspaces/core/export.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "mlspaces/core/transform.h"
#include "mlspaces/library/registry.h"
#include "mlspaces/sim/renderer.h"

namespace mlspaces::sim {

using Rgb8 = std::array<uint8_t, 3>;

/// An 8-bit RGB image: width*height*3 bytes, rows top to bottom.
struct MLSPACES_API Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;

  /// A width x height image filled with `fill`. @throws UsageError for a negative size.
  static Image Filled(int width, int height, Rgb8 fill = {255, 255, 255});
  /// The pixel at (x, y); no bounds check.
  Rgb8 At(int x, int y) const;
};

// ---------------------------------------------------------------------------------------------
// Files

/// Writes `image` as an 8-bit RGB PNG (libpng): to a temp file beside `path`, renamed into
/// place. @throws Error naming the path for an empty image or a write failure.
MLSPACES_API void WritePng(const std::filesystem::path& path, const Image& image);
/// The PNG `image` would be written as, in memory.
MLSPACES_API std::string EncodePng(const Image& image);
/// Reads a PNG (any bit depth or colour type, converted to 8-bit RGB; alpha dropped).
/// @throws Error naming the path for a missing or malformed file.
MLSPACES_API Image ReadPng(const std::filesystem::path& path);

// ---------------------------------------------------------------------------------------------
// Drawing

/// Width and height in pixels of `text` drawn at `scale` (one line; bytes outside printable
/// ASCII are drawn as '?').
MLSPACES_API std::array<int, 2> TextSize(std::string_view text, int scale = 1);
/// Draws `text` with its top-left corner at (x, y), clipped to the image.
MLSPACES_API void DrawText(Image& image, int x, int y, std::string_view text, Rgb8 color,
                           int scale = 1);
/// Fills the rectangle [x, x+w) x [y, y+h), clipped to the image.
MLSPACES_API void FillRect(Image& image, int x, int y, int w, int h, Rgb8 color);

/// The longest side of a grid ComposeGrid makes: 16384 pixels, which image viewers and
/// browsers still open (a 57 x 57 sheet of 256² tiles is 14,824 x 16,192, 720 MB as RGB).
inline constexpr int kMaxGridSide = 16384;
/// The width and height ComposeGrid gives `n` tiles of `tile_width` x `tile_height` in
/// `columns` columns (0: about square), with a title strip when `titled`.
/// @throws UsageError when n < 1, a side is not positive, or the grid would be wider or
/// taller than kMaxGridSide (the message gives the size and how to make it smaller).
MLSPACES_API std::array<int, 2> GridSize(size_t n, int tile_width, int tile_height, int columns = 0,
                                         bool titled = false);
/// Tiles of one size in a grid, `columns` per row (0: about square), each with its label (may
/// be empty; cut with "..." to the tile width) in black on white below it, `title` (may be
/// empty) in a strip across the top. @throws UsageError for tiles of different sizes, labels
/// not one per tile, no tiles, or a grid larger than GridSize allows.
MLSPACES_API Image ComposeGrid(const std::vector<Image>& tiles,
                               const std::vector<std::string>& labels, int columns = 0,
                               std::string_view title = {});

// ---------------------------------------------------------------------------------------------
// Rendering

/// The tile sides, in pixels, that `mlspaces render` and mlspaces.render accept.
inline constexpr int kMinPictureSide = 8;
inline constexpr int kMaxPictureSide = 8192;

/// Size and GL of each rendered tile.
struct MLSPACES_API PictureOptions {
  int width = 256;
  int height = 256;
  GlBackend backend = GlBackend::kOsMesa;
  /// EGL's device platform by default, a device chosen as RenderOptions::egl_device = -1 does.
  EglPlatform egl_platform = EglPlatform::kDevice;
  /// Where nothing is hit (the far plane) the tile gets this colour, else MuJoCo's clear colour
  /// or skybox is kept.
  bool plain_background = true;
  Rgb8 background{235, 235, 235};
};

/// Views of a box: `n` cameras on a circle around `center` at `elevation_deg` above the
/// horizontal, the first from azimuth `azimuth_deg` (0 = from +x, counter-clockwise seen from
/// above), all far enough for a sphere of `radius` to fill about 80% of the vertical field
/// of view. @throws UsageError for n < 1 or radius <= 0.
MLSPACES_API std::vector<CameraView> OrbitViews(const std::array<double, 3>& center, double radius,
                                                int n, double elevation_deg = 30,
                                                double azimuth_deg = -45, double fovy_deg = 45);

/// The world box holding every geom of `m` that the default visual options draw (groups 0-2,
/// alpha > 0, planes left out) where `d` places it (geom_aabb at geom_xpos/xmat):
/// {min x, y, z, max x, y, z}; all zero for a model without such geoms.
MLSPACES_API std::array<double, 6> GeomBounds(const mjModel* m, const mjData* d);

/// Renders the state in `d` from each view into one tile each (one Renderer for all).
/// @throws Error from the Renderer (GL missing, ...).
MLSPACES_API std::vector<Image> RenderViews(const mjModel* m, const mjData* d,
                                            const std::vector<CameraView>& views,
                                            const PictureOptions& options);

/// How a grasp is drawn: a parallel gripper in the grasp (TCP) frame, +z the approach out of
/// the palm, fingers opened along +-y: two fingers of `finger_length` ending at the TCP,
/// `opening` apart, a palm bar joining them and a stem of `stem_length` behind the palm,
/// capsules of `radius` (raised to about 1.5 pixels of the picture for large assets).
struct MLSPACES_API GripperOutline {
  double opening = 0.085;  ///< franka_droid's finger_range[1]
  double finger_length = 0.045;
  double stem_length = 0.04;
  double radius = 0.002;
};

/// The colour of grasp `i` in grasp pictures: a fixed cycle of saturated colours, red left out
/// (green first).
MLSPACES_API Rgb8 GraspColor(size_t i);

/// One asset alone (a studio scene: lights, no floor), framed from a three-quarter view above
/// its front right. @throws Error for an unknown or not-installed UID, or a model MuJoCo
/// rejects; Error from the Renderer.
MLSPACES_API Image RenderAsset(const Registry& registry, std::string_view uid,
                               const PictureOptions& options);

/// A contact sheet: RenderAsset of each UID, labelled with the UID, in a grid (`columns` as
/// ComposeGrid). `progress(i, n)` (may be empty) is called before asset i.
/// @throws UsageError for no UIDs or a sheet larger than GridSize allows (before rendering
/// any); Error as RenderAsset (naming the UID).
MLSPACES_API Image AssetSheet(const Registry& registry, const std::vector<std::string>& uids,
                              const PictureOptions& options, int columns = 0,
                              const std::function<void(size_t, size_t)>& progress = {});

/// The asset with `grasps` drawn as gripper outlines (GraspColor(i)), from `views` orbit
/// views, labelled by azimuth, titled with the UID (and joint) and the grasp count. `grasps`
/// are TCP poses as grasp files store them: in the asset body's frame, or for joint grasps
/// (`joint` = the joint's name in the asset MJCF) in the frame of the body owning that joint.
/// @throws UsageError for views < 1; Error as RenderAsset, or for a joint the asset lacks
/// (naming its joints).
MLSPACES_API Image GraspPicture(const Registry& registry, std::string_view uid,
                                const std::vector<Mat4>& grasps, const GripperOutline& outline,
                                const PictureOptions& options, int views = 4,
                                std::string_view joint = {});

}  // namespace mlspaces::sim
