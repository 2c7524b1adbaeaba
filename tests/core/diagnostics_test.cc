// Diagnostic's one-line form and the collector.
#include "mlspaces/core/diagnostics.h"

#include <gtest/gtest.h>

namespace mlspaces {
namespace {

TEST(DiagnosticsTest, OneLineLeavesOutEmptyParts) {
  EXPECT_EQ((Diagnostic{"a.json", "/x", "bad"}).ToString(), "a.json: /x: bad");
  EXPECT_EQ((Diagnostic{"a.json", "", "bad"}).ToString(), "a.json: bad");
  EXPECT_EQ((Diagnostic{"", "traj_0/rewards", "missing"}).ToString(), "traj_0/rewards: missing");
  EXPECT_EQ((Diagnostic{"f.h5", "", ""}).ToString(), "f.h5");
  // The uid and the severity are not printed.
  EXPECT_EQ((Diagnostic{"f", "g", "m", "uid", Severity::kWarning}).ToString(), "f: g: m");
}

TEST(DiagnosticsTest, OneLineEscapesControlCharactersFromInput) {
  // A file name, HDF5 path or UID from input never moves the cursor or breaks the line.
  EXPECT_EQ((Diagnostic{"a\nb.json", "/x\x1b[2J", "uid red\rblock"}).ToString(),
            "a\\x0ab.json: /x\\x1b[2J: uid red\\x0dblock");
}

TEST(DiagnosticsTest, CollectorCountsErrors) {
  Diagnostics d;
  EXPECT_TRUE(d.ok());
  d.Warning("w.json", "", "odd");
  EXPECT_TRUE(d.ok());
  d.Error("e.json", "/k", "bad", "red_block");
  EXPECT_FALSE(d.ok());
  EXPECT_EQ(d.size(), 2u);
  EXPECT_EQ(d.errors(), 1u);
  EXPECT_EQ(d.items()[1].uid, "red_block");
  EXPECT_EQ(d.items()[0].severity, Severity::kWarning);
  const std::vector<Diagnostic> taken = d.Take();
  EXPECT_EQ(taken.size(), 2u);
}

}  // namespace
}  // namespace mlspaces
