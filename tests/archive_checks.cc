#include "tests/archive_checks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <utility>

#include "analyze/judge/judge.h"
#include "store/archive.h"
#include "store/reanalysis.h"
#include "tests/test_util.h"

namespace imuqual::testing {
namespace {

// Bound on one `imuqual reanalyze --check` (a soak's run takes well under a
// second; a damaged run record must not hang the test).
constexpr int kReanalyzeTimeoutS = 60;

// Bit for bit, and NaN (not measured) equal to NaN.
bool SameValue(double a, double b) {
  return (std::isnan(a) && std::isnan(b)) || std::memcmp(&a, &b, sizeof a) == 0;
}

// The archived judgement of a run (verdict, reasons, every measurement's
// value and outcome) is the re-analysis's: `imuqual reanalyze --check`
// compares the curves only.
void ExpectJudgementEqualsReanalysis(store::Archive& a, const std::string& id) {
  auto result = a.LoadResult(**a.FindRunKey(id));
  ASSERT_TRUE(result.ok() && result->has_value()) << id << ": no judgement archived";
  auto again = store::ReanalyzeRun(a, id);
  ASSERT_TRUE(again.ok()) << id << ": " << again.status().ToString();
  const store::ResultRecord& live = **result;
  EXPECT_EQ(live.verdict, judge::OutcomeName(again->judgement.verdict)) << id;
  EXPECT_EQ(live.reasons, again->judgement.reasons) << id;
  EXPECT_EQ(live.samples, again->samples) << id;
  EXPECT_EQ(live.gap_samples, again->gap_samples) << id;
  // The archive keeps measurements in its own order: compared by axis and name.
  std::map<std::pair<std::string, std::string>, const pb::Measurement*> archived;
  for (const pb::Measurement& m : live.measurements) archived[{m.axis(), m.name()}] = &m;
  EXPECT_EQ(archived.size(), again->measurements.size()) << id;
  for (const pb::Measurement& y : again->measurements) {
    const std::string what = id + " " + y.axis() + " " + y.name();
    auto it = archived.find({y.axis(), y.name()});
    if (it == archived.end()) {
      ADD_FAILURE() << what << ": not archived";
      continue;
    }
    const pb::Measurement& x = *it->second;
    EXPECT_TRUE(SameValue(x.value(), y.value()))
        << what << ": archived " << x.value() << ", re-analysed " << y.value();
    EXPECT_EQ(x.outcome(), y.outcome()) << what;
  }
}

}  // namespace

std::map<std::string, RunCheck> CheckArchive(const std::string& db) {
  std::map<std::string, RunCheck> out;
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  EXPECT_TRUE(a.ok()) << a.status().ToString();
  if (!a.ok()) return out;
  auto integrity = (*a)->db().Prepare("PRAGMA integrity_check");
  EXPECT_TRUE(*integrity->Step());
  EXPECT_EQ(integrity->Text(0), "ok");
  auto s = (*a)->db().Prepare(
      "SELECT r.run_id, x.chunks, r.last_seq, x.gap_ranges, r.state, COALESCE(r.verdict, ''), "
      "COALESCE(r.reasons, '') FROM runs r JOIN run_archive x USING (run_id)");
  while (*s->Step()) {
    RunCheck c{s->Int(1), s->Int(2), s->Int(3), s->Text(4), s->Text(5), s->Text(6)};
    out[s->Text(0)] = c;
  }
  return out;
}

void ExpectEveryRunWhole(const std::map<std::string, RunCheck>& runs) {
  for (const auto& [id, c] : runs) {
    EXPECT_EQ(c.state, "complete") << id << ": " << c.reasons;
    EXPECT_EQ(c.chunks, c.last_seq + 1) << id;
    EXPECT_EQ(c.gap_ranges, 0) << id;
    EXPECT_NE(c.verdict, "") << id << " has no verdict";
  }
}

void ExpectSoakArchivedWhole(const std::string& db, size_t runs, size_t axes) {
  const auto archived = CheckArchive(db);
  std::string listed;
  for (const auto& [id, c] : archived) listed += "\n  " + id + " (" + c.state + ")";
  ASSERT_EQ(archived.size(), runs) << "archived runs:" << listed;
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  ExpectEveryRunWhole(archived);
  for (const auto& [id, c] : archived) {
    auto curves = (*a)->LoadCurves(**(*a)->FindRunKey(id));
    ASSERT_TRUE(curves.ok()) << curves.status().ToString();
    EXPECT_EQ(curves->size(), axes) << id;
    EXPECT_EQ(
        *(*a)->db().QueryInt("SELECT samples_archived FROM run_archive WHERE run_id = '" + id +
                             "'"),
        *(*a)->db().QueryInt("SELECT samples_announced FROM runs WHERE run_id = '" + id + "'"))
        << id << ": samples archived (left) differ from those announced (right)";
    const auto check =
        RunCommand("timeout " + std::to_string(kReanalyzeTimeoutS) + " " + Bin("imuqual") +
                   " reanalyze " + id + " --check --db " + db + " 2>&1 > /dev/null");
    EXPECT_EQ(check.exit_code, 0) << id << (check.exit_code == 124 ? ": timed out" : "") << ": "
                                  << check.output;
    if (check.exit_code != 124) ExpectJudgementEqualsReanalysis(**a, id);
  }
}

}  // namespace imuqual::testing
