// The licence policy in datagen (docs/licenses.md): the tutorial copied here with license_info
// added to its block. Under commercial_safe a scene holding a non-commercial asset is refused
// before anything is simulated; every episode's provenance records its assets' licences and
// the policy, and config.yaml the policy.
#include <cstdlib>
#include <filesystem>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mlspaces/core/error.h"
#include "mlspaces/core/json.h"
#include "mlspaces/datagen/dataset_validate.h"
#include "mlspaces/datagen/journal.h"
#include "mlspaces/datagen/run.h"
#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

/// The tutorial project copied into `dir`, its block licensed `license` (by, by-nc, ...).
fs::path TutorialWithLicense(const fs::path& dir, const std::string& license) {
  fs::path project = dir / "project";
  fs::create_directories(dir);
  fs::copy(fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets", project, fs::copy_options::recursive);
  for (const char* name : {"red_block.json", "red_block_computed.json"}) {
    const fs::path file = project / "asset_library/red_block" / name;
    Json meta = ParseJsonFile(file);
    meta["license_info"] = Json{{"license", license},
                                {"creator_display_name", "Carol"},
                                {"creator_profile_url", "https://sketchfab.com/carol"}};
    fs::permissions(file, fs::perms::owner_write, fs::perm_options::add);
    testing::WriteText(file, meta.dump(4));
  }
  return project;
}

ExperimentConfig Config(const fs::path& project, const fs::path& output, int64_t episodes) {
  ExperimentConfig c = LoadConfigFile(project / "datagen.yaml", ConfigRegistry::WithBuiltins());
  c.output_dir = output;
  c.seed = 3;
  c.task_sampler_config.samples_per_house = episodes;
  c.task_sampler_config.max_allowed_sequential_task_sampler_failures = 2;
  c.task_config.enable_rendering = false;
  return c;
}

/// traj_0's provenance attribute, read by h5py.
Json Provenance(const fs::path& dir, const fs::path& h5) {
  std::string out;
  testing::RunPython(dir, R"(
import h5py, sys
print(h5py.File(sys.argv[1], "r")["traj_0"].attrs["provenance"])
)",
                     testing::ShellQuote(h5.string()), &out);
  return ParseJson(out, h5.string());
}

TEST(LicensePolicyDatagenTest, CommercialSafeRefusesTheSceneBeforeSimulating) {
  testing::TempDir dir;
  const fs::path project = TutorialWithLicense(dir.path(), "by-nc");
  ExperimentConfig config = Config(project, dir / "refused", 1);
  config.license_policy = LicensePolicy::kCommercialSafe;
  const RunReport report = RunDatagen(config, TaskSamplerRegistry::WithBuiltins());
  EXPECT_EQ(report.episodes_kept, 0);
  EXPECT_EQ(report.physics_steps, 0);  // nothing simulated
  EXPECT_TRUE(report.batch_files.empty());
  const std::vector<AttemptRecord> attempts = ReadJournal(dir / "refused/journal.jsonl").records;
  ASSERT_EQ(attempts.size(), 2u);  // max_allowed_sequential_task_sampler_failures
  for (const AttemptRecord& a : attempts) {
    EXPECT_EQ(a.outcome, Outcome::kSamplerReject);
    EXPECT_THAT(a.message, HasSubstr("is refused: licence policy commercial_safe: asset "
                                     "red_block is CC-BY-NC-4.0 (non-commercial)"));
  }
  EXPECT_THAT(testing::Slurp(dir / "refused/config.yaml"),
              HasSubstr("license_policy: commercial_safe"));

  // The same through MLSPACES_LICENSE_POLICY with a null config key: recorded in config.yaml.
  ::setenv("MLSPACES_LICENSE_POLICY", "commercial_safe", 1);
  const RunReport by_env =
      RunDatagen(Config(project, dir / "env", 1), TaskSamplerRegistry::WithBuiltins());
  ::unsetenv("MLSPACES_LICENSE_POLICY");
  EXPECT_EQ(by_env.episodes_kept, 0);
  EXPECT_THAT(testing::Slurp(dir / "env/config.yaml"),
              HasSubstr("license_policy: commercial_safe"));
  // Resuming it without the variable keeps the recorded policy (same data hash).
  RunOptions resume;
  resume.resume = true;
  EXPECT_NO_THROW(
      RunDatagen(Config(project, dir / "env", 1), TaskSamplerRegistry::WithBuiltins(), resume));
}

TEST(LicensePolicyDatagenTest, ProvenanceRecordsLicencesAndThePolicy) {
  testing::TempDir dir;
  // "all": the non-commercial block is used, and its licence recorded.
  const fs::path nc = TutorialWithLicense(dir / "nc", "by-nc");
  const RunReport all = RunDatagen(Config(nc, dir / "all", 1), TaskSamplerRegistry::WithBuiltins());
  ASSERT_EQ(all.batch_files.size(), 1u);
  const Json p = Provenance(dir.path(), all.batch_files[0]);
  ASSERT_EQ(p["assets"].size(), 1u);
  EXPECT_EQ(p["assets"][0]["uid"], "red_block");
  EXPECT_EQ(p["assets"][0]["library"], "custom_assets");
  EXPECT_EQ(p["assets"][0]["license"], "CC-BY-NC-4.0");
  EXPECT_EQ(p["license_policy"], "all");
  EXPECT_THAT(testing::Slurp(dir / "all/config.yaml"), HasSubstr("license_policy: null"));

  // commercial_safe with a CC-BY block: kept, and recorded under the policy.
  const fs::path by = TutorialWithLicense(dir / "by", "by");
  ExperimentConfig safe = Config(by, dir / "safe", 1);
  safe.license_policy = LicensePolicy::kCommercialSafe;
  const RunReport kept = RunDatagen(safe, TaskSamplerRegistry::WithBuiltins());
  ASSERT_EQ(kept.batch_files.size(), 1u);
  const Json q = Provenance(dir.path(), kept.batch_files[0]);
  EXPECT_EQ(q["assets"][0]["license"], "CC-BY-4.0");
  EXPECT_EQ(q["license_policy"], "commercial_safe");
  EXPECT_TRUE(ValidateDataset(dir / "safe").ok());
  // validate-dataset reports a non-commercial asset in an episode made under commercial_safe.
  testing::RunPython(dir.path(), R"(
import h5py, json, sys
with h5py.File(sys.argv[1], "r+") as f:
    p = json.loads(f["traj_0"].attrs["provenance"])
    p["assets"][0]["license"] = "CC-BY-NC-SA-4.0"
    f["traj_0"].attrs["provenance"] = json.dumps(p)
)",
                     testing::ShellQuote(kept.batch_files[0].string()));
  const DatasetReport report = ValidateDataset(dir / "safe");
  ASSERT_EQ(report.problems.size(), 1u);
  EXPECT_THAT(report.problems[0].ToString(),
              HasSubstr("traj_0@provenance/assets/0/license: CC-BY-NC-SA-4.0 (non-commercial) "
                        "under license_policy commercial_safe"));
}

TEST(LicensePolicyDatagenTest, ConfigKeyAndFlagAreChecked) {
  testing::TempDir dir;
  testing::WriteText(dir / "bad.yaml", "license_policy: research_only\n");
  testing::ExpectError([&] { LoadConfigFile(dir / "bad.yaml", ConfigRegistry::WithBuiltins()); },
                       {"license_policy", "research_only"});
  testing::WriteText(dir / "good.yaml", "license_policy: commercial_safe\n");
  EXPECT_EQ(LoadConfigFile(dir / "good.yaml", ConfigRegistry::WithBuiltins()).license_policy,
            LicensePolicy::kCommercialSafe);
  const testing::CliResult bad = testing::RunCli(
      {"datagen", (fs::path(MLSPACES_EXAMPLES_DIR) / "custom_assets/datagen.yaml").string(),
       "--license-policy", "nc", "--output", (dir / "out").string()});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, HasSubstr("--license-policy: unknown licence policy 'nc'"));
}

}  // namespace
}  // namespace mlspaces::datagen
