// Licence resolution (resources/license.h) and the licence policy (library/license_policy.h):
// every rule of the original's license_utils.py, its errors, user libraries and the substring
// identifier validation, against manifests and tries written here.
#include "mlspaces/resources/license.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/library/annotation.h"
#include "mlspaces/library/license_policy.h"
#include "mlspaces/library/registry.h"
#include "test_util.h"

namespace mlspaces {
namespace {

namespace fs = std::filesystem;
using testing::ExpectError;
using ::testing::HasSubstr;
using testing::TempDir;
using testing::WriteText;

/// license_info of a Sketchfab asset with this short name.
Json Info(const std::string& license, const std::string& url = "https://sketchfab.com/alice") {
  return Json{{"license", license},
              {"uri", "https://sketchfab.com/3d-models/x"},
              {"creator_username", "alice"},
              {"creator_display_name", "Alice A"},
              {"creator_profile_url", url}};
}

/// A user library `name` in dir/name: uid -> metadata JSON.
fs::path WriteLibrary(const fs::path& dir, const std::string& name,
                      const std::vector<std::pair<std::string, Json>>& assets) {
  fs::path root = dir / name;
  Json index = Json::object();
  for (const auto& [uid, meta] : assets) {
    WriteText(root / uid / (uid + ".xml"), "<mujoco/>");
    WriteText(root / uid / (uid + ".json"), meta.dump(4));
    index[uid] = Json{{"uid", uid},
                      {"object_path", uid + "/" + uid + ".xml"},
                      {"metadata_path", uid + "/" + uid + ".json"},
                      {"metadata_npz_path", nullptr}};
  }
  WriteText(root / "assets_index.json", index.dump(4));
  return root;
}

Json Objaverse(const std::string& uid, const Json& info) {
  Json j{{"assetId", uid}, {"category", "mug"}, {"isObjaverse", true}};
  if (!info.is_null()) j["license_info"] = info;
  return j;
}

class LicenseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    assets_ = tmp_ / "assets";
    cache_ = tmp_ / "cache";
    // Built-in annotations stand in a user library (the rules read isObjaverse, not the name).
    WriteLibrary(tmp_.path(), "annotated",
                 {{"obj_by", Objaverse("obj_by", Info("by"))},
                  {"obj_bysa", Objaverse("obj_bysa", Info("by-sa"))},
                  {"obj_cc0", Objaverse("obj_cc0", Info("cc0"))},
                  {"obj_nc", Objaverse("obj_nc", Info("by-nc"))},
                  {"obj_ncsa", Objaverse("obj_ncsa", Info("by-nc-sa"))},
                  {"obj_gpl", Objaverse("obj_gpl", Info("gpl"))},
                  {"obj_other_site", Objaverse("obj_other_site", Info("by", "https://x.org/a"))},
                  {"obj_noinfo", Objaverse("obj_noinfo", Json())},
                  {"Mug_3", Json{{"assetId", "Mug_3"}, {"isObjaverse", false}}}});
    registry_.RegisterAssetLibrary("annotated", tmp_ / "annotated");
    // Size manifests: objects in the install tree (a GLOBAL source), grasps and scenes in the
    // cache, found through the install manifest's version.
    WriteText(
        assets_ / "objects/thor/mjthor_resource_file_to_size_mb.json",
        R"({"thor_Bowl_1.tar.zst": 1.5, "thor_Bowl_10.tar.zst": 2, "thor_Cup_2.tar.zst": 1})");
    WriteText(assets_ / "objects/objaverse/mjthor_resource_file_to_size_mb.json",
              R"({"objaverse_aaa111.tar.zst": 1, "objaverse_bbb222.tar.zst": 1})");
    WriteText(assets_ / "mjthor_data_type_to_source_to_versions.json",
              R"({"grasps": {"droid": "20251116"}, "scenes": {"procthor-10k-train": "v1"}})");
    WriteText(cache_ / "grasps/droid/20251116/mjthor_resource_file_to_size_mb.json",
              R"({"droid_Mug.tar.zst": 3, "droid_Bowl.tar.zst": 1})");
    WriteText(cache_ / "grasps/droid/20251117/mjthor_resource_file_to_size_mb.json",
              R"({"droid_Old.tar.zst": 3})");
    WriteText(cache_ / "scenes/procthor-10k-train/v1/mjthor_resource_file_to_size_mb.json",
              R"({"procthor-10k-train_base.tar.zst": 1, "procthor-10k-train_0_99.tar.zst": 9})");
    context_ = LicenseContext{&registry_, assets_, cache_};
  }

  Json Resolve(const std::string& type, const std::string& source, const std::string& id) {
    return ResolveLicense(context_, type, source, id);
  }

  TempDir tmp_;
  fs::path assets_, cache_;
  Registry registry_;
  LicenseContext context_;
};

TEST_F(LicenseTest, ObjaverseByHasTheOriginalsRecord) {
  const Json r = Resolve("objects", "objaverse", "obj_by");
  std::vector<std::string> keys;
  for (const auto& [k, v] : r.items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{
                      "data_type", "data_source", "asset_id", "creator_username",
                      "creator_display_name", "creator_profile_url", "source", "uri", "downloaded",
                      "license_determination", "modifications", "dataset_license", "license",
                      "license_url", "derivative_notice", "attribution"}));
  EXPECT_EQ(r["asset_id"], "obj_by");
  EXPECT_EQ(r["source"], "Sketchfab");
  EXPECT_EQ(r["license"], "CC-BY-4.0");
  EXPECT_EQ(r["attribution"], "Model by Alice A (alice), licensed under CC BY 4.0.");
  EXPECT_FALSE(r.contains("commercial_use"));
}

TEST_F(LicenseTest, EveryCreativeCommonsNameMapsAsTheOriginal) {
  struct Case {
    const char* uid;
    const char* spdx;
    const char* url_part;
    bool nc;
    const char* attribution_end;
  };
  for (const Case& c :
       {Case{"obj_bysa", "CC-BY-SA-4.0", "/by-sa/4.0/", false, "licensed under CC BY-SA 4.0."},
        Case{"obj_cc0", "CC0-1.0", "/zero/1.0/", false, "licensed under CC0-1.0."},
        Case{"obj_nc", "CC-BY-NC-4.0", "/by-nc/4.0/", true,
             "licensed under CC BY-NC 4.0. Non-commercial use only."},
        Case{"obj_ncsa", "CC-BY-NC-SA-4.0", "/by-nc-sa/4.0/", true,
             "licensed under CC BY-NC-SA 4.0. Non-commercial use only."}}) {
    SCOPED_TRACE(c.uid);
    const Json r = Resolve("objects", "objaverse", c.uid);
    EXPECT_EQ(r["license"], c.spdx);
    EXPECT_THAT(r["license_url"].get<std::string>(), HasSubstr(c.url_part));
    EXPECT_EQ(r.contains("commercial_use"), c.nc);
    if (c.nc) {
      EXPECT_EQ(r["commercial_use"], false);
    }
    EXPECT_THAT(r["attribution"].get<std::string>(), ::testing::EndsWith(c.attribution_end));
  }
  EXPECT_EQ(Resolve("objects", "objaverse", "obj_ncsa")["derivative_license"],
            "This derivative work is licensed under CC BY-NC-SA 4.0.");
}

TEST_F(LicenseTest, ObjaverseErrors) {
  ExpectError([&] { Resolve("objects", "objaverse", "obj_gpl"); },
              {"annotated: /license_info/license: Got unsupported license gpl"});
  ExpectError([&] { Resolve("objects", "objaverse", "obj_other_site"); },
              {"Only sketchfab assets expected, got https://x.org/a"});
  ExpectError([&] { Resolve("objects", "objaverse", "obj_noinfo"); }, {"/license_info", "missing"});
  ExpectError([&] { Resolve("objects", "objaverse", "Mug_3"); },
              {"identifier='Mug_3' is not in `objaverse`"});
  // No annotation: validated against the archive names, then no annotation to read.
  ExpectError([&] { Resolve("objects", "objaverse", "bbb"); }, {"no annotation for bbb222"});
  ExpectError([&] { Resolve("objects", "objaverse", "zzz"); },
              {"identifier='zzz' is not in source='objaverse' (data_type='objects')",
               "2 identifiers: aaa111, bbb222"});
}

TEST_F(LicenseTest, ThorIsAi2AndValidatesBySubstringFirstMatchWins) {
  const Json annotated = Resolve("objects", "thor", "Mug_3");
  EXPECT_EQ(annotated["asset_id_or_archive_name"], "Mug_3");
  EXPECT_EQ(annotated["license"], "CC-BY-4.0");
  EXPECT_EQ(annotated["creator_name"], "Allen Institute for AI (Ai2)");
  EXPECT_EQ(annotated["source"], "In-house");
  EXPECT_EQ(annotated["attribution"],
            "Model(s) by the Allen Institute for AI (Ai2), licensed under CC BY 4.0.");
  // "Bowl_1" is in thor_Bowl_1 and thor_Bowl_10: the first in manifest order wins.
  EXPECT_EQ(Resolve("objects", "thor", "Bowl_1")["asset_id_or_archive_name"], "Bowl_1");
  EXPECT_EQ(Resolve("objects", "thor", "Bowl_10")["asset_id_or_archive_name"], "Bowl_10");
  EXPECT_EQ(Resolve("objects", "thor", "Cup")["asset_id_or_archive_name"], "Cup_2");
  ExpectError([&] { Resolve("objects", "thor", "obj_by"); },
              {"identifier='obj_by' is not in `thor`"});
  ExpectError([&] { Resolve("objects", "thor", "Plate"); },
              {"identifier='Plate' is not in source='thor'",
               "3 identifiers: Bowl_1, Bowl_10, "
               "Cup_2"});
}

TEST_F(LicenseTest, ObjathorMetadataAndUnknownSources) {
  const Json r = Resolve("objects", "objathor_metadata", "anything");
  EXPECT_EQ(r["asset_id"], "anything");
  EXPECT_EQ(r["relationship_to_objects"], "annotation");
  // Printed as Python's json.dumps does (ASCII, the en dash escaped).
  EXPECT_THAT(r.dump(2, ' ', true), HasSubstr("CLIP embedding\\u2013based"));
  ExpectError([&] { Resolve("objects", "nope", "x"); },
              {"Can't determine license for `objects` with data_source='nope' and "
               "identifier='x'"});
  ExpectError([&] { Resolve("textures", "nope", "x"); }, {"Non-valid data_type='textures'"});
}

TEST_F(LicenseTest, UserLibrariesResolveLicenseInfoOrSayUnknown) {
  fs::create_directories(tmp_ / "tutorial");
  const fs::path lib = testing::CopyExampleLibrary(tmp_ / "tutorial");
  // A second asset carrying license_info (by-nc), a third with a non-CC licence.
  WriteText(lib / "nc_block/nc_block.xml", "<mujoco/>");
  Json meta = ParseJsonFile(lib / "red_block/red_block.json");
  meta["assetId"] = "nc_block";
  meta["license_info"] = Json{{"license", "by-nc"}, {"creator_display_name", "Bob"}};
  WriteText(lib / "nc_block/nc_block.json", meta.dump(4));
  meta["assetId"] = "mit_block";
  meta["license_info"] = Json{{"license", "MIT"}};
  WriteText(lib / "mit_block/mit_block.xml", "<mujoco/>");
  WriteText(lib / "mit_block/mit_block.json", meta.dump(4));
  Json index = ParseJsonFile(lib / "assets_index.json");
  for (const char* uid : {"nc_block", "mit_block"}) {
    index[uid] = Json{{"uid", uid},
                      {"object_path", std::string(uid) + "/" + uid + ".xml"},
                      {"metadata_path", std::string(uid) + "/" + uid + ".json"},
                      {"metadata_npz_path", nullptr}};
  }
  WriteText(lib / "assets_index.json", index.dump(4));
  registry_.RegisterAssetLibrary("custom_assets", lib);

  const Json unknown = Resolve("objects", "custom_assets", "red_block");
  EXPECT_EQ(unknown["license"], "unknown");
  EXPECT_THAT(unknown["license_determination"].get<std::string>(), HasSubstr("no license_info"));
  const Json nc = Resolve("objects", "custom_assets", "nc_block");
  EXPECT_EQ(nc["license"], "CC-BY-NC-4.0");
  EXPECT_EQ(nc["commercial_use"], false);
  EXPECT_EQ(nc["attribution"],
            "Model by Bob, licensed under CC BY-NC 4.0. Non-commercial use only.");
  EXPECT_EQ(Resolve("objects", "custom_assets", "mit_block")["license"], "MIT");
  ExpectError([&] { Resolve("objects", "custom_assets", "obj_by"); },
              {"identifier='obj_by' is not in user library `custom_assets`", "annotated"});
  EXPECT_EQ(DefaultObjectSource(registry_, "nc_block"), "custom_assets");
  EXPECT_EQ(DefaultObjectSource(registry_, "nope"), std::nullopt);
  // The one-word answer of episode provenance.
  EXPECT_EQ(AssetLicenseName("custom_assets", registry_.GetAnnotation("nc_block").get()),
            "CC-BY-NC-4.0");
  EXPECT_EQ(AssetLicenseName("custom_assets", registry_.GetAnnotation("red_block").get()),
            "unknown");
  EXPECT_EQ(AssetLicenseName("thor", nullptr), "CC-BY-4.0");
}

TEST_F(LicenseTest, GraspsListTheirTargetsFromTheTries) {
  // droid's pinned version (20251116) is the one the install manifest names.
  const fs::path version = cache_ / "grasps/droid/20251116";
  ASSERT_EQ(testing::RunPython(tmp_.path(), R"(
import gzip, json, sys
tries = {"droid_Mug.tar.zst": {"Mug_3": {"Mug_3_grasps_filtered.npz": {},
                                         "Mug_3_object_info.json": {}},
                               "Mug_7/Mug_7_grasps_filtered.json": {}},
         "droid_Bowl.tar.zst": {"Bowl_1": {"Bowl_1_grasps_filtered.npz": {}}}}
with gzip.open(sys.argv[1], "wt") as f:
    json.dump(tries, f)
)",
                               (version / "mjthor_resources_combined_meta.json.gz").string()),
            0);
  const Json r = Resolve("grasps", "droid", "Mug");
  EXPECT_EQ(r["asset_id"], "Mug");
  EXPECT_EQ(r["attribution"],
            "Grasps generated by the Allen Institute for AI (Ai2), licensed under CC BY 4.0.");
  EXPECT_EQ(r["external_target_assets"],
            Json::parse(R"j({"thor": [{"identifier": "Mug_3", "attribution":
                "Model(s) by the Allen Institute for AI (Ai2), licensed under CC BY 4.0."}],
                "ithor builtin": [{"identifier": "Mug_7 (ithor scene builtin)", "attribution":
                "Asset(s) by the Allen Institute for AI (Ai2), licensed under CC BY 4.0."}]})j"));
  ExpectError([&] { Resolve("grasps", "droid", "Old"); },
              {"identifier='Old' is not in source='droid' (data_type='grasps')"});
}

TEST_F(LicenseTest, ScenesByIndexListTheirAssetsAndByNameMustBeUnique) {
  const fs::path dir = assets_ / "scenes/procthor-10k-train";
  WriteText(dir / "train_5.xml", "<mujoco/>");
  WriteText(dir / "train_5_metadata.json",
            R"({"objects": {"mug_0": {"asset_id": "Mug_3", "is_static": false},
                            "cup_0": {"asset_id": "obj_nc", "is_static": false},
                            "wall_0": {"asset_id": "wall", "is_static": true}}})");
  const Json r = Resolve("scenes", "procthor-10k-train", "5");
  EXPECT_EQ(r["asset_id"], "5");
  EXPECT_EQ(r["attribution"],
            "Scene by the Allen Institute for AI (Ai2), licensed under CC BY 4.0.");
  ASSERT_TRUE(r.contains("assets"));
  // By the annotations' isObjaverse: Mug_3 is thor, obj_nc objaverse; "wall" is no asset.
  EXPECT_EQ(r["assets"].size(), 2u);
  EXPECT_EQ(r["assets"]["thor"][0]["identifier"], "Mug_3");
  EXPECT_EQ(r["assets"]["objaverse"][0]["identifier"], "obj_nc");
  EXPECT_THAT(r["assets"]["objaverse"][0]["attribution"].get<std::string>(),
              HasSubstr("Non-commercial use only."));
  EXPECT_EQ(Resolve("scenes", "procthor-10k-train", "train_5")["asset_id"], "5");
  ExpectError([&] { Resolve("scenes", "procthor-10k-train", "6"); }, {"is not installed"});
  ExpectError([&] { Resolve("scenes", "procthor-10k-train", "val_5"); },
              {"Non-valid identifier val_5"});
  EXPECT_FALSE(Resolve("scenes", "procthor-10k-train", "base").contains("assets"));
  ExpectError([&] { Resolve("scenes", "procthor-10k-train", "train"); }, {"multiple archives"});
  ExpectError([&] { Resolve("scenes", "procthor-10k-train", "nothing"); },
              {"No archives for `scenes` procthor-10k-train nothing"});
}

TEST_F(LicenseTest, RobotsAndMissingManifests) {
  const Json r = Resolve("robots", "franka_droid", "");
  EXPECT_EQ(r["asset_id"], "franka_droid");
  EXPECT_EQ(r["license"], "Apache 2.0");
  EXPECT_EQ(Resolve("robots", "humans_rocketbox", "walker")["license"], "MIT");
  ExpectError([&] { Resolve("robots", "spot", ""); }, {"Got unknown robot spot"});
  ExpectError([&] { Resolve("grasps", "droid_objaverse", "x"); },
              {"no size manifest for grasps/droid_objaverse"});
  WriteText(assets_ / "objects/bad/mjthor_resource_file_to_size_mb.json", "[1, 2]");
  ExpectError([&] { SourceArchiveNames(context_, "objects", "bad"); },
              {"mjthor_resource_file_to_size_mb.json", "expected an object"});
  EXPECT_EQ(ArchiveIdentifier("objaverse_aaa111.tar.zst", "objaverse"), "aaa111");
}

TEST(LicensePolicyTest, ParsesResolvesAndDecides) {
  EXPECT_EQ(ParseLicensePolicy("commercial_safe"), LicensePolicy::kCommercialSafe);
  EXPECT_EQ(ParseLicensePolicy("all"), LicensePolicy::kAll);
  EXPECT_THROW(ParseLicensePolicy("nc"), UsageError);
  ::setenv("MLSPACES_LICENSE_POLICY", "commercial_safe", 1);
  EXPECT_EQ(ResolveLicensePolicy(), LicensePolicy::kCommercialSafe);
  EXPECT_EQ(ResolveLicensePolicy(LicensePolicy::kAll), LicensePolicy::kAll);
  ::setenv("MLSPACES_LICENSE_POLICY", "bogus", 1);
  EXPECT_THROW(ResolveLicensePolicy(), UsageError);
  ::unsetenv("MLSPACES_LICENSE_POLICY");
  EXPECT_EQ(ResolveLicensePolicy(), LicensePolicy::kAll);

  EXPECT_TRUE(IsNonCommercialLicense(" BY-NC "));
  EXPECT_TRUE(IsNonCommercialLicense("by-nc-sa"));
  EXPECT_FALSE(IsNonCommercialLicense("by-sa"));
  EXPECT_EQ(SpdxLicenseName("cc0"), "CC0-1.0");
  EXPECT_EQ(SpdxLicenseName("gpl"), std::nullopt);
  Annotation nc{"u", "lib", Json{{"license_info", {{"license", "by-nc"}}}}, {}};
  Annotation by{"u", "lib", Json{{"license_info", {{"license", "by"}}}}, {}};
  EXPECT_FALSE(AllowedByLicensePolicy(LicensePolicy::kCommercialSafe, &nc));
  EXPECT_TRUE(AllowedByLicensePolicy(LicensePolicy::kAll, &nc));
  EXPECT_TRUE(AllowedByLicensePolicy(LicensePolicy::kCommercialSafe, &by));
  EXPECT_TRUE(AllowedByLicensePolicy(LicensePolicy::kCommercialSafe, nullptr));
}

}  // namespace
}  // namespace mlspaces
