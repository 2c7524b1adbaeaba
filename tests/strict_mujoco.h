// The strict MuJoCo test main (tests/strict_mujoco_main.cc), linked into the sim and datagen
// suites: MuJoCo's handlers are installed before any test, and a test that leaves a MuJoCo
// warning on its thread fails, naming the warning. A test that provokes a warning on purpose
// consumes it with ExpectMujocoWarning, which fails when no such warning came.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::testing {

/// Consumes this thread's MuJoCo warnings; expects one of them to contain `part`.
/// Returns all of them (the expected one included).
inline std::vector<std::string> ExpectMujocoWarning(std::string_view part) {
  std::vector<std::string> warnings = sim::TakeMujocoWarnings();
  bool found = false;
  for (const std::string& w : warnings) found = found || w.find(part) != std::string::npos;
  EXPECT_TRUE(found) << "expected a MuJoCo warning containing \"" << part << "\", got "
                     << warnings.size() << " warning(s)"
                     << (warnings.empty() ? "" : ", the first: " + warnings.front());
  return warnings;
}

}  // namespace mlspaces::testing
