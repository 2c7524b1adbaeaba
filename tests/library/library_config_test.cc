#include "mlspaces/library/library_config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/library/registry.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::TempDir;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

class LibraryConfigTest : public ::testing::Test {
 protected:
  void SetUp() override { yaml_ = dir_ / "libs.yaml"; }

  /// The error of loading `text`, as (what, field).
  std::pair<std::string, std::string> YamlError(const std::string& text) {
    WriteFileAtomic(yaml_, text);
    try {
      LibraryConfig::LoadYaml(yaml_);
    } catch (const Error& e) {
      EXPECT_EQ(e.path(), yaml_.string());
      return {e.what(), e.field()};
    }
    return {"<no error>", ""};
  }

  TempDir tmp_;
  const fs::path dir_ = tmp_.path();
  fs::path yaml_;
};

TEST_F(LibraryConfigTest, LoadsAndResolvesRelativePaths) {
  WriteFileAtomic(yaml_, R"(# comment
assets_dir: assets
asset_libraries:
  - {name: custom_assets, path: asset_library}
  - name: abs
    path: /data/abs
grasp_libraries:
  - {name: custom_grasps, path: ./asset_library/, asset_library: custom_assets}
)");
  const LibraryConfig config = LibraryConfig::LoadYaml(yaml_);
  ASSERT_TRUE(config.assets_dir.has_value());
  EXPECT_EQ(*config.assets_dir, dir_ / "assets");
  ASSERT_EQ(config.asset_libraries.size(), 2u);
  EXPECT_EQ(config.asset_libraries[0].name, "custom_assets");
  EXPECT_EQ(config.asset_libraries[0].dir, dir_ / "asset_library");
  EXPECT_EQ(config.asset_libraries[0].origin_line, "line 4");
  EXPECT_EQ(config.asset_libraries[1].dir, fs::path("/data/abs"));
  ASSERT_EQ(config.grasp_libraries.size(), 1u);
  EXPECT_EQ(config.grasp_libraries[0].name, "custom_grasps");
  EXPECT_EQ(config.grasp_libraries[0].dir.lexically_normal(), dir_ / "asset_library/");
  EXPECT_EQ(config.grasp_libraries[0].asset_library, "custom_assets");
}

TEST_F(LibraryConfigTest, EmptyAndNullListsAreFine) {
  EXPECT_EQ(YamlError("").first, "<no error>");
  EXPECT_EQ(YamlError("asset_libraries:\ngrasp_libraries: []\n").first, "<no error>");
}

TEST_F(LibraryConfigTest, BadYamlNamesFileAndLine) {
  auto [what, field] = YamlError("asset_libraries:\n  - {name: a, path: b}\n  - {name: [\n");
  EXPECT_THAT(what, HasSubstr("invalid YAML"));
  EXPECT_THAT(field, ::testing::StartsWith("line "));

  std::tie(what, field) =
      YamlError("asset_libraries:\n  - name: a\n    path: b\n    colour: red\n");
  EXPECT_THAT(what, HasSubstr("asset_libraries[0].colour: unknown key (valid keys: name, path)"));
  EXPECT_EQ(field, "line 4");

  std::tie(what, field) = YamlError("assets_dir: x\nlibraries: []\n");
  EXPECT_THAT(what, HasSubstr("libraries: unknown key ("));
  EXPECT_EQ(field, "line 2");

  std::tie(what, field) = YamlError("asset_libraries:\n  - name: [a]\n    path: b\n");
  EXPECT_THAT(what, HasSubstr("asset_libraries[0].name: expected a string, got a list"));
  EXPECT_EQ(field, "line 2");

  std::tie(what, field) = YamlError("asset_libraries: {name: a}\n");
  EXPECT_THAT(what, HasSubstr("asset_libraries: expected a list, got a mapping"));
  EXPECT_EQ(field, "line 1");

  std::tie(what, field) = YamlError("asset_libraries:\n  - name: a\n");
  EXPECT_THAT(what, HasSubstr("asset_libraries[0]: missing 'path'"));
  EXPECT_EQ(field, "line 2");

  std::tie(what, field) = YamlError("grasp_libraries:\n  - {name: g, path: p}\n");
  EXPECT_THAT(what, HasSubstr("missing 'asset_library'"));

  std::tie(what, field) = YamlError("asset_libraries:\n  - {name: a/b, path: p}\n");
  EXPECT_THAT(what, HasSubstr("must not contain slashes"));
  EXPECT_EQ(field, "line 2");

  std::tie(what, field) = YamlError("asset_libraries:\n  - {name: a, path: p, path: q}\n");
  EXPECT_THAT(what, HasSubstr("asset_libraries[0].path: duplicate key"));

  std::tie(what, field) = YamlError("- just\n- a list\n");
  EXPECT_THAT(what, HasSubstr("top level: expected a mapping, got a list"));

  std::tie(what, field) = YamlError("assets_dir:\n");
  EXPECT_THAT(what, HasSubstr("assets_dir: expected a path, got null"));
}

TEST_F(LibraryConfigTest, MissingFile) {
  EXPECT_THROW(LibraryConfig::LoadYaml(dir_ / "nope.yaml"), Error);
}

TEST_F(LibraryConfigTest, FlagParsers) {
  AssetLibrarySpec a = LibraryConfig::ParseAssetFlag("custom=some/dir=x");
  EXPECT_EQ(a.name, "custom");
  EXPECT_EQ(a.dir, fs::path("some/dir=x"));
  for (std::string bad : {"custom", "=dir", "custom=", ""}) {
    try {
      LibraryConfig::ParseAssetFlag(bad);
      FAIL() << bad;
    } catch (const UsageError& e) {
      EXPECT_THAT(e.what(), HasSubstr("NAME=DIR, got '" + bad + "'"));
    }
  }
  GraspLibrarySpec g = LibraryConfig::ParseGraspFlag("g=C:/dir:with:colons:custom_assets");
  EXPECT_EQ(g.name, "g");
  EXPECT_EQ(g.dir, fs::path("C:/dir:with:colons"));
  EXPECT_EQ(g.asset_library, "custom_assets");
  for (std::string bad : {"g=dir", "g=dir:", "g=:lib", "=dir:lib", "g:lib=dir", "gdir:lib"}) {
    try {
      LibraryConfig::ParseGraspFlag(bad);
      FAIL() << bad;
    } catch (const UsageError& e) {
      EXPECT_THAT(e.what(), HasSubstr("NAME=DIR:ASSET_LIBRARY, got '" + bad + "'"));
    }
  }
}

TEST_F(LibraryConfigTest, ApplyToRegistersInOrderAndLocatesErrors) {
  fs::create_directories(dir_ / "lib");
  WriteFileAtomic(dir_ / "lib/assets_index.json",
                  R"({"u": {"uid": "u", "object_path": "u.xml", "metadata_path": "u.json",
                      "metadata_npz_path": null}})");
  WriteFileAtomic(dir_ / "lib/grasps_index.json", R"({"grasp_paths": {"r": {"u": "g.npz"}}})");
  WriteFileAtomic(yaml_, R"(asset_libraries:
  - {name: one, path: lib}
grasp_libraries:
  - {name: g, path: lib, asset_library: one}
)");
  Registry registry;
  LibraryConfig::LoadYaml(yaml_).ApplyTo(registry);
  EXPECT_THAT(registry.asset_libraries(), ElementsAre("one"));
  EXPECT_THAT(registry.grasp_libraries_of("one"), ElementsAre("g/r"));
  EXPECT_EQ(registry.LocateOrThrow("u").mjcf_path, dir_ / "lib/u.xml");

  WriteFileAtomic(yaml_, R"(asset_libraries:
  - {name: two, path: lib}
grasp_libraries:
  - {name: h, path: lib, asset_library: missing}
)");
  try {
    LibraryConfig::LoadYaml(yaml_).ApplyTo(registry);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.message(), "Object library missing not found");
    EXPECT_EQ(e.path(), yaml_.string());
    EXPECT_EQ(e.field(), "line 4");
  }
}

}  // namespace
}  // namespace mlspaces
