#include "mlspaces/library/scene_metadata.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;

class SceneMetadataTest : public ::testing::Test {
 protected:
  void Touch(const fs::path& p, const std::string& text = R"({"objects": {}})") {
    WriteFileAtomic(p, text);
  }
  TempDir tmp_;
  const fs::path dir_ = tmp_.path();
};

TEST_F(SceneMetadataTest, PrimaryNames) {
  Touch(dir_ / "scene_metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(dir_ / "scene.xml"), dir_ / "scene_metadata.json");
  Touch(dir_ / "FloorPlan1_physics_metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(dir_ / "FloorPlan1_physics.xml"),
            dir_ / "FloorPlan1_physics_metadata.json");
  Touch(dir_ / "train_1_metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(dir_ / "train_1_ceiling.xml"), dir_ / "train_1_metadata.json");
}

TEST_F(SceneMetadataTest, FallsBackCuttingAtUnderscores) {
  Touch(dir_ / "a_metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(dir_ / "a_b_c.xml"), dir_ / "a_metadata.json");
  Touch(dir_ / "a_b_metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(dir_ / "a_b_c.xml"), dir_ / "a_b_metadata.json");
  // A ceiling variant also falls back on its full stem.
  EXPECT_EQ(FindSceneMetadataFile(dir_ / "a_b_ceiling.xml"), dir_ / "a_b_metadata.json");
  // Empty parts are kept, as str.split does: "x__y" tries "x__y", "x_", "x".
  Touch(dir_ / "x__metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(dir_ / "x__y.xml"), dir_ / "x__metadata.json");
  EXPECT_FALSE(FindSceneMetadataFile(dir_ / "nothing_here.xml").has_value());
  EXPECT_FALSE(LoadSceneMetadata(dir_ / "nothing_here.xml").has_value());
}

TEST_F(SceneMetadataTest, OnlyTheFileNameMatters) {
  // The original tests "ceiling" against the full path, and rewrites every ".xml".
  const fs::path ceiling_dir = dir_ / "ceiling_scenes";
  Touch(ceiling_dir / "house_metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(ceiling_dir / "house.xml"), ceiling_dir / "house_metadata.json");
  const fs::path xml_dir = dir_ / "v.xml.d";
  Touch(xml_dir / "s_metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(xml_dir / "s.xml"), xml_dir / "s_metadata.json");
  // "ceiling" in the name but not as the _ceiling suffix: the plain rule.
  Touch(dir_ / "ceilingfan_metadata.json");
  EXPECT_EQ(FindSceneMetadataFile(dir_ / "ceilingfan.xml"), dir_ / "ceilingfan_metadata.json");
}

TEST_F(SceneMetadataTest, RequiresXml) {
  try {
    FindSceneMetadataFile(dir_ / "scene.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("Scene is supposed to be xml ("));
    EXPECT_THAT(e.what(), HasSubstr("scene.json given)"));
  }
  EXPECT_THROW(FindSceneMetadataFile(dir_ / "x.xml" / ""), Error);
}

TEST_F(SceneMetadataTest, LoadValidates) {
  Touch(dir_ / "ok_metadata.json", R"({"objects": {"b": {"asset_id": "u"}}, "other": 1})");
  std::optional<Json> ok = LoadSceneMetadata(dir_ / "ok.xml");
  ASSERT_TRUE(ok.has_value());
  EXPECT_EQ((*ok)["objects"]["b"]["asset_id"], "u");
  Touch(dir_ / "list_metadata.json", "[1]");
  EXPECT_THROW(LoadSceneMetadata(dir_ / "list.xml"), Error);
  Touch(dir_ / "objs_metadata.json", R"({"objects": []})");
  try {
    LoadSceneMetadata(dir_ / "objs.xml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "/objects");
  }
  Touch(dir_ / "bad_metadata.json", "{");
  EXPECT_THROW(LoadSceneMetadata(dir_ / "bad.xml"), Error);
}

TEST_F(SceneMetadataTest, InsertedObjects) {
  Annotation a;
  a.uid = "red_block";
  a.library = "custom_assets";
  a.json = Json::parse(R"({"category": "block", "boundingBox": {"x": 0.05}})");
  Json entry = MakeInsertedObjectEntry(a, "/lib/red_block.xml");
  EXPECT_EQ(entry, Json::parse(R"({"asset_id": "red_block", "category": "block",
      "object_enum": "temp_object", "is_static": false, "boundingBox": {"x": 0.05},
      "asset_library": "custom_assets", "mjcf_path": "/lib/red_block.xml"})"));
  a.json.erase("boundingBox");
  EXPECT_EQ(MakeInsertedObjectEntry(a, "/x.xml")["boundingBox"], Json::object());
  a.json.erase("category");
  EXPECT_THROW(MakeInsertedObjectEntry(a, "/x.xml"), Error);

  Json none;  // a scene without metadata: created, not a crash
  EXPECT_TRUE(AddSceneObject(none, "body_1", entry));
  EXPECT_EQ(none["objects"]["body_1"]["asset_id"], "red_block");
  Json other = entry;
  other["asset_id"] = "other";
  EXPECT_FALSE(AddSceneObject(none, "body_1", other));  // first write wins
  EXPECT_EQ(none["objects"]["body_1"]["asset_id"], "red_block");
  Json no_objects = Json::parse(R"({"rooms": []})");
  EXPECT_TRUE(AddSceneObject(no_objects, "b", entry));
  EXPECT_TRUE(no_objects["objects"].contains("b"));
  Json bad = Json::parse(R"({"objects": 3})");
  EXPECT_THROW(AddSceneObject(bad, "b", entry), Error);
}

TEST_F(SceneMetadataTest, SceneObjectAssetId) {
  auto message = [](const std::optional<Json>& meta, const std::string& body) {
    try {
      SceneObjectAssetId(meta, body);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("<no error>");
  };
  EXPECT_EQ(message(std::nullopt, "b"),
            "Could not load grasps for object b: No scene metadata found!");
  const Json meta = Json::parse(
      R"({"objects": {"b": {"asset_id": "u"}, "n": {"asset_id": 3}, "m": {"category": "x"}}})");
  EXPECT_EQ(SceneObjectAssetId(meta, "b"), "u");
  EXPECT_EQ(message(meta, "zz"),
            "Could not load grasps for object zz: Object not found in scene metadata!");
  EXPECT_THAT(message(meta, "n"), HasSubstr("asset_id must be a string"));
  EXPECT_THAT(message(meta, "m"), HasSubstr("missing asset_id"));
  EXPECT_THAT(message(Json::parse("{}"), "b"), HasSubstr("Object not found in scene metadata!"));
}

}  // namespace
}  // namespace mlspaces
