// Checks shared by the task suites (tests/datagen/tasks/<task>/): one run's bytes against its
// runs with workers, shards and an interrupted-then-resumed run. Include as
// "datagen/tasks/task_run_checks.h".
#pragma once

#include <functional>
#include <map>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "mlspaces/datagen/config.h"
#include "mlspaces/datagen/run.h"
#include "test_util.h"

namespace mlspaces::testing {

/// Runs config("one") (one worker), then config("two") with 2 workers, config("shards") as
/// two shards sharing one folder and config("cut") interrupted at its first attempt then
/// resumed; each must write the HDF5 batch files of "one" byte for byte, and "one" writes
/// `batch_files` of them. `config(name)` gives a config whose output folder is `dir / name`.
inline void ExpectWorkersShardsAndResumeGiveTheSameBytes(
    const std::function<datagen::ExperimentConfig(const std::string&)>& config,
    const std::filesystem::path& dir, size_t batch_files) {
  using datagen::RunDatagen;
  using datagen::RunOptions;
  using datagen::TaskSamplerRegistry;
  RunDatagen(config("one"), TaskSamplerRegistry::WithBuiltins());
  const std::map<std::string, std::string> one = FilesByExtension(dir / "one", {".h5"});
  ASSERT_EQ(one.size(), batch_files);
  RunOptions two;
  two.workers = 2;
  RunDatagen(config("two"), TaskSamplerRegistry::WithBuiltins(), two);
  EXPECT_TRUE(FilesByExtension(dir / "two", {".h5"}) == one);
  for (int i = 0; i < 2; ++i) {  // two shards sharing one folder
    RunOptions shard;
    shard.shard = datagen::Shard{i, 2};
    RunDatagen(config("shards"), TaskSamplerRegistry::WithBuiltins(), shard);
  }
  EXPECT_TRUE(FilesByExtension(dir / "shards", {".h5"}) == one);
  RunOptions stop;
  stop.on_attempt = [&](const datagen::WorkItem&, const datagen::AttemptRecord&) {
    throw std::runtime_error("interrupted");
  };
  EXPECT_THROW(RunDatagen(config("cut"), TaskSamplerRegistry::WithBuiltins(), stop),
               std::runtime_error);
  RunOptions resume;
  resume.resume = true;
  RunDatagen(config("cut"), TaskSamplerRegistry::WithBuiltins(), resume);
  EXPECT_TRUE(FilesByExtension(dir / "cut", {".h5"}) == one);
}

}  // namespace mlspaces::testing
