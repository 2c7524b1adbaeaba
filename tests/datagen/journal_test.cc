// The attempt journal: JSON lines round trip, crash tolerance, strict reading, summary.
#include "mlspaces/datagen/journal.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util.h"

namespace mlspaces::datagen {
namespace {

namespace fs = std::filesystem;
using ::mlspaces::testing::ExpectError;
using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::mlspaces::testing::WriteText;
using ::testing::HasSubstr;

AttemptRecord Record(int64_t episode, int attempt, Outcome outcome, double plan, double rollout) {
  AttemptRecord r;
  r.scene = "house_8";
  r.episode = episode;
  r.attempt = attempt;
  r.seed = 0xfedcba9876543210ULL + static_cast<uint64_t>(episode);  // above INT64_MAX
  r.outcome = outcome;
  r.message = outcome == Outcome::kSuccess ? "" : "failed: \"quoted\"\nsecond line";
  r.AddTiming("plan", plan);
  r.AddTiming("rollout", rollout);
  return r;
}

TEST(OutcomeTest, NamesAreStableAndRoundTrip) {
  const std::vector<std::string> expected = {"sampler_reject", "no_grasp", "ik_fail", "collision",
                                             "grasp_slip",     "timeout",  "success"};
  ASSERT_EQ(kAllOutcomes.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(static_cast<size_t>(kAllOutcomes[i]), i);
    EXPECT_EQ(OutcomeName(kAllOutcomes[i]), expected[i]);
    EXPECT_EQ(OutcomeFromName(expected[i]), kAllOutcomes[i]);
  }
  EXPECT_EQ(OutcomeFromName("Success"), std::nullopt);
  EXPECT_EQ(OutcomeFromName(""), std::nullopt);
}

TEST(AttemptRecordTest, AddTimingSumsRepeatsAndKeepsOrder) {
  AttemptRecord r;
  r.AddTiming("b", 1);
  r.AddTiming("a", 2);
  r.AddTiming("b", 0.5);
  ASSERT_EQ(r.timings.size(), 2u);
  EXPECT_EQ(r.timings[0].first, "b");
  EXPECT_EQ(r.Timing("b"), 1.5);
  EXPECT_EQ(r.Timing("a"), 2);
  EXPECT_EQ(r.Timing("missing"), 0);
}

TEST(JournalTest, RoundTripOneLinePerAttempt) {
  TempDir dir;
  const fs::path path = dir / "runs/a/journal.jsonl";  // folders are created
  std::vector<AttemptRecord> written = {Record(0, 0, Outcome::kIkFail, 0.25, 0),
                                        Record(0, 1, Outcome::kSuccess, 0.125, 3.5)};
  written[1].extra = Json{{"lift", 0.08}, {"grasp", 17}};
  {
    Journal journal(path);
    EXPECT_EQ(journal.truncated_bytes(), 0u);
    for (const AttemptRecord& r : written) journal.Append(r);
  }
  const std::string text = Slurp(path);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 2);
  EXPECT_THAT(text, HasSubstr("\"outcome\":\"ik_fail\""));
  EXPECT_THAT(text, HasSubstr("\"timings\":{\"plan\":0.25,\"rollout\":0.0}"));
  // Reopening appends after what is there.
  {
    Journal journal(path);
    journal.Append(Record(1, 0, Outcome::kTimeout, 1, 2));
  }
  written.push_back(Record(1, 0, Outcome::kTimeout, 1, 2));
  const JournalContents read = ReadJournal(path);
  EXPECT_FALSE(read.truncated_tail);
  EXPECT_EQ(read.records, written);
  EXPECT_EQ(read.records[0].seed, 0xfedcba9876543210ULL);
  EXPECT_EQ(read.records[0].message, "failed: \"quoted\"\nsecond line");
  EXPECT_EQ(read.records[1].extra["grasp"], 17);
}

TEST(JournalTest, EmptyJournalReadsAsNothing) {
  TempDir dir;
  { Journal journal(dir / "j.jsonl"); }
  const JournalContents read = ReadJournal(dir / "j.jsonl");
  EXPECT_TRUE(read.records.empty());
  EXPECT_FALSE(read.truncated_tail);
}

TEST(JournalTest, TruncatedLastLineIsIgnoredAndCutOnReopen) {
  TempDir dir;
  const fs::path path = dir / "j.jsonl";
  {
    Journal journal(path);
    journal.Append(Record(0, 0, Outcome::kSuccess, 1, 2));
    journal.Append(Record(1, 0, Outcome::kGraspSlip, 1, 2));
  }
  // A crash in the middle of the third write.
  const std::string full = Slurp(path);
  const std::string partial = R"({"scene":"house_8","episode":2,"att)";
  WriteText(path, full + partial);

  JournalContents read = ReadJournal(path);
  EXPECT_TRUE(read.truncated_tail);
  ASSERT_EQ(read.records.size(), 2u);
  EXPECT_EQ(read.records[1].outcome, Outcome::kGraspSlip);

  {
    Journal journal(path);
    EXPECT_EQ(journal.truncated_bytes(), partial.size());
    EXPECT_EQ(Slurp(path), full);
    journal.Append(Record(2, 0, Outcome::kSuccess, 1, 2));
  }
  read = ReadJournal(path);
  EXPECT_FALSE(read.truncated_tail);
  ASSERT_EQ(read.records.size(), 3u);
  EXPECT_EQ(read.records[2].episode, 2);
}

TEST(JournalTest, FileWithOnlyAPartialLineIsCutToEmpty) {
  TempDir dir;
  const fs::path path = dir / "j.jsonl";
  WriteText(path, R"({"scene":)");
  EXPECT_TRUE(ReadJournal(path).truncated_tail);
  Journal journal(path);
  EXPECT_EQ(journal.truncated_bytes(), 9u);
  EXPECT_EQ(Slurp(path), "");
}

TEST(JournalTest, CorruptMiddleLineIsAnErrorWithItsLineNumber) {
  TempDir dir;
  const fs::path path = dir / "j.jsonl";
  {
    Journal journal(path);
    journal.Append(Record(0, 0, Outcome::kSuccess, 1, 2));
  }
  const std::string good = Slurp(path);
  WriteText(path, good + R"({"scene":"x","episode":1,"att)" + "\n" + good);
  ExpectError([&] { ReadJournal(path); }, {path.string(), "line 2", "bad JSON"});
}

TEST(JournalTest, BadFieldsNameLineAndKey) {
  TempDir dir;
  const fs::path path = dir / "j.jsonl";
  const std::string good = Record(0, 0, Outcome::kSuccess, 1, 2).ToJson().dump() + "\n";
  auto with = [&](const std::string& key, const Json& value) {
    Json j = Record(0, 0, Outcome::kSuccess, 1, 2).ToJson();
    if (value.is_discarded()) {
      j.erase(key);
    } else {
      j[key] = value;
    }
    WriteText(path, good + good + j.dump() + "\n");
  };
  with("outcome", "exploded");
  ExpectError([&] { ReadJournal(path); }, {"line 3", "/outcome", "unknown outcome \"exploded\""});
  with("episode", -1);
  ExpectError([&] { ReadJournal(path); }, {"line 3", "/episode", "integer"});
  with("seed", Json(Json::value_t::discarded));
  ExpectError([&] { ReadJournal(path); }, {"line 3", "/seed", "missing"});
  with("timings", Json{{"plan", "slow"}});
  ExpectError([&] { ReadJournal(path); }, {"line 3", "/timings/plan", "expected number"});
  with("timings", Json{{"plan", -1}});
  ExpectError([&] { ReadJournal(path); }, {"line 3", "plan", ">= 0"});
  with("colour", "red");
  ExpectError([&] { ReadJournal(path); }, {"line 3", "/colour", "unknown key"});
  WriteText(path, good + "\n" + good);
  ExpectError([&] { ReadJournal(path); }, {"line 2", "bad JSON"});
  WriteText(path, good + "[1, 2]\n");
  ExpectError([&] { ReadJournal(path); }, {"line 2", "expected a JSON object"});
  ExpectError([&] { ReadJournal(dir / "missing.jsonl"); }, {"missing.jsonl"});
}

TEST(JournalTest, AppendRejectsBadRecordsAndWritesNothing) {
  TempDir dir;
  const fs::path path = dir / "j.jsonl";
  Journal journal(path);
  AttemptRecord r = Record(0, 0, Outcome::kSuccess, 1, 2);
  r.timings.emplace_back("plan", 1);  // pushed directly: a duplicate stage
  EXPECT_THROW(journal.Append(r), Error);
  r = Record(0, 0, Outcome::kSuccess, std::numeric_limits<double>::quiet_NaN(), 2);
  EXPECT_THROW(journal.Append(r), Error);
  r = Record(0, 0, Outcome::kSuccess, 1, 2);
  r.extra = Json::array({1});
  EXPECT_THROW(journal.Append(r), Error);
  EXPECT_EQ(Slurp(path), "");
}

TEST(JournalTest, MovedJournalKeepsWriting) {
  TempDir dir;
  Journal a(dir / "j.jsonl");
  Journal b = std::move(a);
  b.Append(Record(0, 0, Outcome::kSuccess, 1, 2));
  EXPECT_THROW(a.Append(Record(0, 1, Outcome::kSuccess, 1, 2)), UsageError);  // NOLINT
  EXPECT_EQ(ReadJournal(dir / "j.jsonl").records.size(), 1u);
}

TEST(SummaryTest, CountsRatesAndMeanStageTimes) {
  std::vector<AttemptRecord> records = {
      Record(0, 0, Outcome::kNoGrasp, 1.0, 0),   Record(0, 1, Outcome::kSuccess, 2.0, 4.0),
      Record(1, 0, Outcome::kIkFail, 3.0, 0),    Record(1, 1, Outcome::kCollision, 1.0, 2.0),
      Record(2, 0, Outcome::kSuccess, 1.0, 6.0), Record(3, 0, Outcome::kSamplerReject, 0, 0),
  };
  records[5].timings.clear();
  records[5].AddTiming("sample", 0.5);
  const JournalSummary s = Summarize(records);
  EXPECT_EQ(s.attempts, 6);
  EXPECT_EQ(s.count(Outcome::kSuccess), 2);
  EXPECT_EQ(s.count(Outcome::kNoGrasp), 1);
  EXPECT_EQ(s.count(Outcome::kIkFail), 1);
  EXPECT_EQ(s.count(Outcome::kCollision), 1);
  EXPECT_EQ(s.count(Outcome::kSamplerReject), 1);
  EXPECT_EQ(s.count(Outcome::kGraspSlip), 0);
  EXPECT_EQ(s.count(Outcome::kTimeout), 0);
  EXPECT_DOUBLE_EQ(s.success_rate(), 2.0 / 6.0);
  EXPECT_EQ(s.episodes, 4);
  EXPECT_EQ(s.successful_episodes, 2);
  ASSERT_EQ(s.stages.size(), 3u);
  EXPECT_EQ(s.stages[0].name, "plan");
  EXPECT_EQ(s.stages[0].runs, 5);
  EXPECT_DOUBLE_EQ(s.stages[0].mean_seconds, 8.0 / 5);
  EXPECT_EQ(s.stages[1].name, "rollout");
  EXPECT_DOUBLE_EQ(s.stages[1].mean_seconds, 12.0 / 5);
  EXPECT_EQ(s.stages[2].name, "sample");
  EXPECT_EQ(s.stages[2].runs, 1);
  EXPECT_DOUBLE_EQ(s.stages[2].total_seconds, 0.5);

  const std::string text = FormatSummary(s);
  EXPECT_THAT(text, HasSubstr("success rate: 33.3% of attempts (2/6), 50.0% of episodes (2/4)"));
  EXPECT_THAT(text, ::testing::ContainsRegex("no_grasp +1 +16\\.7%"));
  EXPECT_THAT(text, ::testing::ContainsRegex("grasp_slip +0 +0\\.0%"));
  EXPECT_THAT(text, ::testing::ContainsRegex("plan +1\\.600000 +5 +8\\.000"));
  EXPECT_EQ(text.back(), '\n');
}

TEST(SummaryTest, EmptyJournal) {
  const JournalSummary s = Summarize({});
  EXPECT_EQ(s.attempts, 0);
  EXPECT_EQ(s.success_rate(), 0);
  EXPECT_THAT(FormatSummary(s), HasSubstr("success rate: 0.0% of attempts (0/0)"));
}

}  // namespace
}  // namespace mlspaces::datagen
