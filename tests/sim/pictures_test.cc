// Pictures: PNG round trip, text and grids at known pixels, the example's red block rendered
// red at the centre of its tile, grasp outlines in their colour, one-line errors.
#include "mlspaces/sim/pictures.h"

#include <algorithm>
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/library/grasp_set.h"
#include "test_util.h"

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;

Registry ExampleRegistry() {
  Registry registry;
  const fs::path lib = fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets" / "asset_library";
  registry.RegisterAssetLibrary("custom_assets", lib);
  registry.RegisterGraspLibrary("custom_grasps", lib, "custom_assets");
  return registry;
}

PictureOptions Small(int w = 64, int h = 48) {
  PictureOptions o;
  o.width = w;
  o.height = h;
  return o;
}

bool IsRed(Rgb8 c) { return c[0] > 120 && c[1] < 60 && c[2] < 60; }

/// Pixels of `image` whose colour `pred` accepts.
template <class Pred>
size_t Count(const Image& image, Pred pred) {
  size_t n = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) n += pred(image.At(x, y)) ? 1 : 0;
  }
  return n;
}

TEST(PicturesTest, PngRoundTripsEveryByte) {
  Image image = Image::Filled(7, 5, {10, 20, 30});
  FillRect(image, 2, 1, 3, 2, {250, 0, 128});
  const testing::TempDir tmp;
  const fs::path& dir = tmp.path();
  WritePng(dir / "a.png", image);
  const Image back = ReadPng(dir / "a.png");
  EXPECT_EQ(back.width, 7);
  EXPECT_EQ(back.height, 5);
  EXPECT_EQ(back.rgb, image.rgb);
  EXPECT_EQ(ReadFile(dir / "a.png").substr(1, 3), "PNG");
  // Nothing else is left beside it (written to a temp file and renamed).
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
}

TEST(PicturesTest, BadPngFilesAreOneLineErrorsNamingTheFile) {
  const testing::TempDir tmp;
  const fs::path& dir = tmp.path();
  WriteFileAtomic(dir / "bad.png", "not a png");
  for (const fs::path& p : {dir / "bad.png", dir / "missing.png"}) {
    try {
      ReadPng(p);
      FAIL() << "no error for " << p;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(WritePng(dir / "empty.png", Image{}), Error);
}

TEST(PicturesTest, TextIsDrawnInItsColourInsideItsBox) {
  Image image = Image::Filled(80, 30);
  const auto [w, h] = TextSize("UID", 2);
  EXPECT_GT(w, 10);
  EXPECT_EQ(h, 18);
  DrawText(image, 5, 5, "UID", {0, 0, 0}, 2);
  size_t inside = 0, outside = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (image.At(x, y) != Rgb8{0, 0, 0}) continue;
      const bool in = x >= 5 && x < 5 + w && y >= 5 && y < 5 + h;
      (in ? inside : outside) += 1;
    }
  }
  EXPECT_GT(inside, 40u);  // 'U' alone is two 7-pixel strokes and a base, at scale 2
  EXPECT_EQ(outside, 0u);
  // The left stroke of the 'U' starts at the text's corner.
  EXPECT_EQ(image.At(5, 5), (Rgb8{0, 0, 0}));
  // Clipped at the border, never written outside.
  DrawText(image, 75, 25, "WWWW", {9, 9, 9}, 3);
  EXPECT_EQ(image.rgb.size(), 80u * 30 * 3);
}

TEST(PicturesTest, GridPlacesTilesAndLabels) {
  std::vector<Image> tiles{Image::Filled(40, 30, {255, 0, 0}), Image::Filled(40, 30, {0, 0, 255}),
                           Image::Filled(40, 30, {0, 255, 0})};
  const Image grid = ComposeGrid(tiles, {"a", "bb", "a very long label to cut"}, 2, "title");
  // Two columns: 4 + 2 * (40 + 4) wide; a title strip, then two rows of tile + label.
  EXPECT_EQ(grid.width, 92);
  const int title_h = 9 * 2 + 6 + 4;
  const int label_h = 9 + 6;
  EXPECT_EQ(grid.height, title_h + 2 * (30 + label_h + 4) + 4);
  EXPECT_EQ(grid.At(4 + 20, title_h + 4 + 15), (Rgb8{255, 0, 0}));
  EXPECT_EQ(grid.At(48 + 20, title_h + 4 + 15), (Rgb8{0, 0, 255}));
  EXPECT_EQ(grid.At(4 + 20, title_h + 4 + 30 + label_h + 4 + 15), (Rgb8{0, 255, 0}));
  EXPECT_EQ(grid.At(0, 0), (Rgb8{255, 255, 255}));
  // The label row under the first tile has black pixels (the text), the margin none.
  size_t dark = 0;
  for (int y = title_h + 4 + 30; y < title_h + 4 + 30 + label_h; ++y) {
    for (int x = 4; x < 44; ++x) dark += grid.At(x, y) == Rgb8{0, 0, 0} ? 1 : 0;
  }
  EXPECT_GT(dark, 5u);
  // The long label stays within its tile's column.
  for (int y = title_h + 2 * (4 + 30) + label_h; y < grid.height; ++y) {
    for (int x = 44; x < grid.width; ++x) EXPECT_EQ(grid.At(x, y), (Rgb8{255, 255, 255}));
  }
  EXPECT_THROW(ComposeGrid(tiles, {"a"}), UsageError);
  EXPECT_THROW(ComposeGrid({}, {}), UsageError);
}

TEST(PicturesTest, AGridIsAtMostTheLargestSideAndSaysSoBeforeRendering) {
  // GridSize is ComposeGrid's size.
  const std::vector<Image> tiles(3, Image::Filled(40, 30, {9, 9, 9}));
  const Image grid = ComposeGrid(tiles, {"a", "b", "c"}, 2, "title");
  EXPECT_EQ(GridSize(3, 40, 30, 2, true), (std::array<int, 2>{grid.width, grid.height}));
  EXPECT_EQ(GridSize(3, 40, 30), (std::array<int, 2>{4 + 2 * 44, 2 * (30 + 15 + 4) + 4}));
  // 57 x 57 tiles of 256² fit (labels at scale 2: 24 pixels); 58 x 58 are too tall.
  EXPECT_EQ(GridSize(57 * 57, 256, 256), (std::array<int, 2>{14824, 16192}));
  testing::ExpectError([] { GridSize(58 * 58, 256, 256); },
                       {"3364 tiles of 256x256 in 58 columns", "16476", "16384"});
  testing::ExpectError([] { GridSize(100, 256, 256, 100); }, {"26004x"});  // too wide
  EXPECT_THROW(GridSize(0, 256, 256), UsageError);
  EXPECT_THROW(GridSize(4, 0, 256), UsageError);
  // A contact sheet that large fails before its first asset is rendered.
  const Registry registry = ExampleRegistry();
  size_t calls = 0;
  const std::vector<std::string> uids(58 * 58, "red_block");
  PictureOptions big = Small();
  big.width = big.height = 256;
  EXPECT_THROW(AssetSheet(registry, uids, big, 0, [&](size_t, size_t) { ++calls; }), UsageError);
  EXPECT_EQ(calls, 0u);
}

TEST(PicturesTest, TheRedBlockRendersRedAtTheCentreOnAPlainBackground) {
  const Registry registry = ExampleRegistry();
  const Image tile = RenderAsset(registry, "red_block", Small());
  ASSERT_EQ(tile.width, 64);
  ASSERT_EQ(tile.height, 48);
  EXPECT_TRUE(IsRed(tile.At(32, 24))) << int(tile.At(32, 24)[0]) << " " << int(tile.At(32, 24)[1]);
  EXPECT_EQ(tile.At(1, 1), (Rgb8{235, 235, 235}));
  EXPECT_EQ(tile.At(62, 46), (Rgb8{235, 235, 235}));
  // Framed: the block covers a good part of the tile but not all of it.
  const size_t red = Count(tile, IsRed);
  EXPECT_GT(red, 64u * 48 / 10);
  EXPECT_LT(red, 64u * 48 * 9 / 10);
}

TEST(PicturesTest, AContactSheetLabelsEachAsset) {
  const Registry registry = ExampleRegistry();
  std::vector<size_t> calls;
  const Image sheet = AssetSheet(registry, {"red_block", "red_block"}, Small(), 0,
                                 [&](size_t i, size_t n) { calls.push_back(i * 10 + n); });
  EXPECT_EQ(calls, (std::vector<size_t>{2, 12}));
  EXPECT_EQ(sheet.width, 4 + 2 * (64 + 4));
  EXPECT_TRUE(IsRed(sheet.At(4 + 32, 4 + 24)));
  EXPECT_TRUE(IsRed(sheet.At(4 + 68 + 32, 4 + 24)));
  size_t dark = 0;
  for (int y = 4 + 48; y < 4 + 48 + 15; ++y) {
    for (int x = 4; x < 4 + 64; ++x) dark += sheet.At(x, y)[0] < 50 ? 1 : 0;
  }
  EXPECT_GT(dark, 10u);  // "red_block" under the first tile
}

TEST(PicturesTest, GraspsAreDrawnAsOutlinesInTheirColour) {
  const Registry registry = ExampleRegistry();
  const GraspSet grasps = registry.LoadGrasps(GraspQuery{"red_block", "", {}}, 3, 0);
  ASSERT_FALSE(grasps.poses.empty());
  PictureOptions o = Small(96, 96);
  const Image with = GraspPicture(registry, "red_block", grasps.poses, GripperOutline{}, o, 2);
  const Image without = GraspPicture(registry, "red_block", {}, GripperOutline{}, o, 2);
  EXPECT_EQ(with.width, 4 + 2 * (96 + 4));
  auto greenish = [](Rgb8 c) { return c[1] > 100 && c[1] > 2 * c[0] && c[1] > c[2] + 40; };
  EXPECT_GT(Count(with, greenish), 20u);
  EXPECT_EQ(Count(without, greenish), 0u);
  EXPECT_GT(Count(without, IsRed), 100u);
  EXPECT_THROW(GraspPicture(registry, "red_block", {}, GripperOutline{}, o, 0), UsageError);
}

TEST(PicturesTest, JointGraspsAreDrawnOnTheBodyOwningTheJoint) {
  Registry registry;
  const fs::path lib = fs::path(MLSPACES_EXAMPLES_DIR) / "objects";
  registry.RegisterAssetLibrary("example_objects", lib);
  registry.RegisterGraspLibrary("example_objects_grasps", lib, "example_objects");
  const GraspSet grasps =
      registry.LoadGrasps(GraspQuery{"cabinet_drawer_door", "drawer_slide", {}}, 4, 0);
  ASSERT_FALSE(grasps.poses.empty());
  const PictureOptions o = Small(96, 96);
  // Seen from the front (the drawer faces -x: azimuth 135 and 225 of four views).
  const Image with = GraspPicture(registry, "cabinet_drawer_door", grasps.poses, GripperOutline{},
                                  o, 4, "drawer_slide");
  const Image without =
      GraspPicture(registry, "cabinet_drawer_door", {}, GripperOutline{}, o, 4, "drawer_slide");
  auto greenish = [](Rgb8 c) { return c[1] > 100 && c[1] > 2 * c[0] && c[1] > c[2] + 40; };
  EXPECT_GT(Count(with, greenish), 5u);
  EXPECT_EQ(Count(without, greenish), 0u);
  const std::string e = testing::ErrorOf([&] {
    GraspPicture(registry, "cabinet_drawer_door", grasps.poses, GripperOutline{}, o, 1, "lid");
  });
  EXPECT_NE(e.find("has no joint 'lid' (joints: "), std::string::npos) << e;
  EXPECT_NE(e.find("drawer_slide"), std::string::npos) << e;
}

TEST(PicturesTest, AnUnknownUidIsOneLineNamingIt) {
  const Registry registry = ExampleRegistry();
  try {
    RenderAsset(registry, "no_such_block", Small());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_block"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
  EXPECT_THROW(AssetSheet(registry, {}, Small()), UsageError);
}

TEST(PicturesTest, OrbitViewsLookAtTheCentreFromAround) {
  const std::vector<CameraView> v = OrbitViews({1, 2, 3}, 0.5, 4, 0, 0);
  ASSERT_EQ(v.size(), 4u);
  EXPECT_GT(v[0].pos[0], 1.5);         // azimuth 0: from +x
  EXPECT_NEAR(v[0].pos[2], 3, 1e-9);   // elevation 0
  EXPECT_GT(v[1].pos[1], 2.5);         // azimuth 90: from +y
  EXPECT_NEAR(v[0].xmat[2], 1, 1e-9);  // camera z (backward) = +x: looks along -x
  EXPECT_THROW(OrbitViews({0, 0, 0}, 0, 1), UsageError);
}

}  // namespace
}  // namespace mlspaces::sim
