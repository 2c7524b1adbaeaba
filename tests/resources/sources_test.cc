// ResolveAssetsDir (src/resources/sources.cc): the one order for the assets dir.
#include "mlspaces/resources/sources.h"

#include <cstdlib>
#include <filesystem>

#include <gtest/gtest.h>

namespace mlspaces {
namespace {
namespace fs = std::filesystem;

// Restores MLSPACES_ASSETS_DIR and HOME on scope exit.
class EnvGuard {
 public:
  EnvGuard() {
    Save("MLSPACES_ASSETS_DIR", assets_);
    Save("HOME", home_);
  }
  ~EnvGuard() {
    Restore("MLSPACES_ASSETS_DIR", assets_);
    Restore("HOME", home_);
  }

 private:
  struct Saved {
    bool set = false;
    std::string value;
  };
  static void Save(const char* name, Saved& s) {
    const char* v = std::getenv(name);
    s.set = v != nullptr;
    if (v) s.value = v;
  }
  static void Restore(const char* name, const Saved& s) {
    if (s.set) {
      ::setenv(name, s.value.c_str(), 1);
    } else {
      ::unsetenv(name);
    }
  }
  Saved assets_, home_;
};

TEST(ResolveAssetsDirTest, GivenThenEnvironmentThenDefault) {
  EnvGuard guard;
  ::setenv("HOME", "/home/someone", 1);
  ::setenv("MLSPACES_ASSETS_DIR", "/from/env", 1);
  AssetsDirChoice c = ResolveAssetsDir(fs::path("rel/flag"));
  EXPECT_EQ(c.dir, fs::path("rel/flag"));  // as given, not made absolute
  EXPECT_EQ(c.origin, AssetsDirOrigin::kGiven);
  c = ResolveAssetsDir();
  EXPECT_EQ(c.dir, fs::path("/from/env"));
  EXPECT_EQ(c.origin, AssetsDirOrigin::kEnvironment);
  ::setenv("MLSPACES_ASSETS_DIR", "", 1);  // empty counts as unset
  c = ResolveAssetsDir(std::nullopt);
  EXPECT_EQ(c.dir, fs::path("/home/someone/.cache/mlspaces/assets"));
  EXPECT_EQ(c.dir, DefaultAssetsDir());
  EXPECT_EQ(c.origin, AssetsDirOrigin::kDefault);
  ::unsetenv("MLSPACES_ASSETS_DIR");
  EXPECT_EQ(ResolveAssetsDir().origin, AssetsDirOrigin::kDefault);
}

TEST(ResolveAssetsDirTest, ResourceSettingsUseTheSameOrder) {
  EnvGuard guard;
  ::setenv("HOME", "/home/someone", 1);
  ::setenv("MLSPACES_ASSETS_DIR", "/from/env", 1);
  EXPECT_EQ(ResourceSettings::FromEnvironment().assets_dir, fs::path("/from/env"));
  ::unsetenv("MLSPACES_ASSETS_DIR");
  EXPECT_EQ(ResourceSettings::FromEnvironment().assets_dir,
            fs::path("/home/someone/.cache/mlspaces/assets"));
}

}  // namespace
}  // namespace mlspaces
