// INCONCLUSIVE end to end: a unit whose measured value sits within its
// uncertainty of a guarded limit is INCONCLUSIVE with that reason, in the
// tables, the report and the exports.
//
// A simulated unit is deterministic by its lot and index, so a first soak
// measures its bias instability (value v, 1-sigma u); a plan is written with
// a GUARDED high limit at v + 0.5 u on that axis (guard band w = 2 u, so the
// value lies within it), and a second soak of the same unit under that plan
// must judge it INCONCLUSIVE, a retest candidate counted in no yield.
#include <gtest/gtest.h>

#include <google/protobuf/util/json_util.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "common/strings.h"
#include "common/text_util.h"
#include "imuqual/record.pb.h"
#include "store/archive.h"
#include "tests/csv_table.h"
#include "tests/test_util.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::RunCommand;

constexpr char kLot[] = "GUARD";
constexpr char kAxis[] = "x";

// The station test's short-soak plan without a bias-instability limit; the
// guarded one is appended.
constexpr char kPlan[] = R"pb(
name: "guarded"
axes { name: "x" kind: GYRO }
axes { name: "y" kind: GYRO }
axes { name: "z" kind: GYRO }
nominal_rate_hz: 100
min_duration_s: 600
warmup_s: 60
grid { kind: OCTAVE }
limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.8 unit: "deg/sqrt(h)" }
limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
)pb";

std::string Exact(double v) {
  return ShortestReal(v);
}

using testing::Csv;
using testing::ParseCsv;

struct Archived {
  std::string serial, run_id, verdict, reasons;
  double value = NAN, uncertainty = NAN, guard_band = NAN, high = NAN;
  std::string outcome, rule;
};

Archived ReadBiasInstability(const std::string& db) {
  Archived a;
  auto archive = store::Archive::Open(db, store::Archive::Mode::kRead);
  EXPECT_TRUE(archive.ok()) << archive.status().ToString();
  if (!archive.ok()) return a;
  auto s = (*archive)->db().Prepare(
      "SELECT r.serial, r.run_id, COALESCE(r.verdict, ''), COALESCE(r.reasons, ''), m.value, "
      "m.uncertainty, m.guard_band, m.high, COALESCE(m.outcome, ''), COALESCE(m.decision_rule, '') "
      "FROM runs r JOIN measurements m ON m.run_key = r.run_key "
      "WHERE m.axis = ?1 AND m.name = 'bias_instability' ORDER BY r.serial");
  EXPECT_TRUE(s.ok());
  s->Bind(1, std::string(kAxis));
  auto row = s->Step();
  EXPECT_TRUE(row.ok() && *row) << "no bias_instability of axis x in " << db;
  if (!row.ok() || !*row) return a;
  a.serial = s->Text(0);
  a.run_id = s->Text(1);
  a.verdict = s->Text(2);
  a.reasons = s->Text(3);
  a.value = s->Real(4);
  a.uncertainty = s->Real(5);
  a.guard_band = s->Real(6);
  a.high = s->Real(7);
  a.outcome = s->Text(8);
  a.rule = s->Text(9);
  return a;
}

class InconclusiveTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir("inconclusive");
    const std::string plain_plan = dir_->path("plain.textproto");
    std::ofstream(plain_plan) << kPlan;
    auto soak = [](const std::string& db, const std::string& plan) {
      return RunCommand(Bin("imuqual") + " run --sim 1 --duration 1200 --rate 100 --lot " + kLot +
                        " --db " + db + " --plan " + plan + " --quiet 2>&1");
    };
    // First soak: what the unit measures.
    const auto first = soak(dir_->path("first.db"), plain_plan);
    ASSERT_EQ(first.exit_code, 0) << first.output;
    measured_ = new Archived(ReadBiasInstability(dir_->path("first.db")));
    ASSERT_TRUE(std::isfinite(measured_->value) && measured_->uncertainty > 0)
        << "the bias instability needs a value and an uncertainty: " << measured_->value << " ± "
        << measured_->uncertainty;
    // The guarded limit half an uncertainty above the value: within w = 2 u.
    high_ = measured_->value + 0.5 * measured_->uncertainty;
    const std::string guarded_plan = dir_->path("guarded.textproto");
    std::ofstream(guarded_plan) << kPlan << "limits { measurement: \"bias_instability\" axes: \""
                                << kAxis << "\" high: " << Exact(high_)
                                << " unit: \"deg/h\" decision_rule: GUARDED guard_k: 2 }\n";
    db_ = dir_->path("guarded.db");
    second_ = new testing::CommandResult(soak(db_, guarded_plan));
  }
  static void TearDownTestSuite() {
    delete second_;
    delete measured_;
    delete dir_;
  }
  static std::string Imuqual(const std::string& args) {
    const auto r = RunCommand(Bin("imuqual") + " " + args + " --db " + db_);
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.output;
    return r.output;
  }

  static testing::TempDir* dir_;
  static std::string db_;
  static Archived* measured_;
  static double high_;
  static testing::CommandResult* second_;
};
testing::TempDir* InconclusiveTest::dir_ = nullptr;
std::string InconclusiveTest::db_;
Archived* InconclusiveTest::measured_ = nullptr;
double InconclusiveTest::high_ = 0;
testing::CommandResult* InconclusiveTest::second_ = nullptr;

TEST_F(InconclusiveTest, TheUnitIsInconclusiveWithTheGuardBandAsItsReason) {
  ASSERT_EQ(second_->exit_code, 0) << second_->output;
  const Archived a = ReadBiasInstability(db_);
  // The same unit measured the same (simulated units are deterministic).
  ASSERT_EQ(a.serial, measured_->serial);
  ASSERT_EQ(a.value, measured_->value) << "the second soak did not reproduce the first";
  ASSERT_EQ(a.uncertainty, measured_->uncertainty);
  EXPECT_EQ(a.high, high_);
  EXPECT_EQ(a.outcome, "INCONCLUSIVE");
  EXPECT_EQ(a.rule, "guarded");
  EXPECT_DOUBLE_EQ(a.guard_band, 2 * a.uncertainty);
  EXPECT_EQ(a.verdict, "INCONCLUSIVE") << a.reasons;
  for (const char* part : {"x: bias_instability ", "within the guard band (w = ",
                           "of the high limit ", ": inconclusive (guarded)"}) {
    EXPECT_NE(a.reasons.find(part), std::string::npos) << part << "\n" << a.reasons;
  }
  // The station's own final table says so, with the reason.
  EXPECT_NE(second_->output.find("INCONCLUSIVE"), std::string::npos) << second_->output;
  EXPECT_NE(second_->output.find("within the guard band"), std::string::npos) << second_->output;
}

TEST_F(InconclusiveTest, LotShowsItInconclusiveAndCountsItAsARetestCandidate) {
  ASSERT_EQ(second_->exit_code, 0);
  const Archived a = ReadBiasInstability(db_);
  const std::string lot = Imuqual(std::string("lot ") + kLot);
  for (const std::string& part : std::vector<std::string>{
           "INCONCLUSIVE", "1 units by their final run: 0 PASS, 0 MARGINAL, 0 FAIL, 1 "
                                     "INCONCLUSIVE",
        "final yield not measurable: no judged unit", "1 retest candidate(s) (INCONCLUSIVE)",
        a.serial + ": x: bias_instability ", "within the guard band",
        " \u00B1 "}) {
    EXPECT_NE(lot.find(part), std::string::npos) << part << "\n" << lot;
  }
  const Csv rows = ParseCsv(Imuqual(std::string("lot ") + kLot + " --format csv"));
  bool found = false;
  for (const auto& r : rows.rows) {
    if (r[rows.Col("axis")] != kAxis) continue;
    found = true;
    EXPECT_EQ(r[rows.Col("verdict")], "INCONCLUSIVE");
    EXPECT_EQ(r[rows.Col("run_verdict")], "INCONCLUSIVE");
    EXPECT_EQ(std::stod(r[rows.Col("bias_instability_deg_hr")]), a.value);
    EXPECT_EQ(std::stod(r[rows.Col("bias_instability_uncertainty")]), a.uncertainty);
    EXPECT_NE(r[rows.Col("axis_reasons")].find("within the guard band"), std::string::npos);
  }
  EXPECT_TRUE(found);
  const Csv lots = ParseCsv(Imuqual("lots --format csv"));
  ASSERT_EQ(lots.rows.size(), 1u);
  EXPECT_EQ(lots.rows[0][lots.Col("inconclusive")], "1");
  EXPECT_EQ(lots.rows[0][lots.Col("yield")], "");  // not measurable: INCONCLUSIVE is not counted
  const Csv runs = ParseCsv(Imuqual(std::string("runs --lot ") + kLot + " --format csv"));
  ASSERT_EQ(runs.rows.size(), 1u);
  EXPECT_EQ(runs.rows[0][runs.Col("verdict")], "INCONCLUSIVE");
  EXPECT_NE(runs.rows[0][runs.Col("reason")].find("within the guard band"), std::string::npos);
  const std::string unit = Imuqual("unit " + a.serial);
  EXPECT_NE(unit.find("INCONCLUSIVE"), std::string::npos) << unit;
  EXPECT_NE(unit.find("within the guard band"), std::string::npos) << unit;
}

TEST_F(InconclusiveTest, TheReportShowsTheBadgeAndTheReason) {
  ASSERT_EQ(second_->exit_code, 0);
  const Archived a = ReadBiasInstability(db_);
  const std::string path = dir_->path("report.html");
  Imuqual(std::string("report --lot ") + kLot + " --output " + path);
  auto html = ReadFileToString(path);
  ASSERT_TRUE(html.ok());
  const std::string reason = a.reasons.substr(0, a.reasons.find('\n'));
  for (const std::string& part : std::vector<std::string>{
           "<span class=\"badge v-INCONCLUSIVE\">INCONCLUSIVE</span>",
        "data-serial=\"" + a.serial + "\" data-run=\"" + a.run_id + "\" data-verdict=\"INCONCLUSIVE\"",
        "<li>" + reason + "</li>",  // the attention list (nothing to escape in it)
        "data-field=\"retest_candidates\" data-v=\"1\"",
        "<td class=\"num o-INCONCLUSIVE\" data-m=\"bias_instability\" data-v=\"" + Exact(a.value) +
            "\" data-u=\"" + Exact(a.uncertainty) + "\"",
        "data-outcome=\"INCONCLUSIVE\""}) {
    EXPECT_NE(html->find(part), std::string::npos) << part;
  }
}

TEST_F(InconclusiveTest, TheLotPlotDrawsTheUnitAsInconclusive) {
  ASSERT_EQ(second_->exit_code, 0);
  const Archived a = ReadBiasInstability(db_);
  const std::string path = dir_->path("lot.svg");
  Imuqual(std::string("plot --lot ") + kLot + " --axis " + kAxis + " -o " + path);
  auto svg = ReadFileToString(path);
  ASSERT_TRUE(svg.ok());
  // Bold, in a shade of the inconclusive violet (the first: #5a32a3), labelled with
  // its verdict: not a FAIL's red.
  EXPECT_NE(svg->find(a.serial + " INCONCLUSIVE"), std::string::npos);
  EXPECT_NE(svg->find("#5a32a3"), std::string::npos);
  EXPECT_NE(svg->find("bands: FAIL, INCONCLUSIVE and MARGINAL units"), std::string::npos);
}

TEST_F(InconclusiveTest, TheExportsCarryTheOutcomeTheRuleAndTheGuardBand) {
  ASSERT_EQ(second_->exit_code, 0);
  const Archived a = ReadBiasInstability(db_);
  const std::string csv_text = Imuqual("export --run " + a.run_id + " --as measurements");
  EXPECT_EQ(csv_text.find("OUTCOME_UNSET"), std::string::npos);
  const Csv csv = ParseCsv(csv_text);
  bool found = false;
  for (const auto& r : csv.rows) {
    if (r[csv.Col("axis")] != kAxis || r[csv.Col("name")] != "bias_instability") continue;
    found = true;
    EXPECT_EQ(r[csv.Col("outcome")], "INCONCLUSIVE");
    EXPECT_EQ(r[csv.Col("decision_rule")], "guarded");
    EXPECT_EQ(std::stod(r[csv.Col("guard_band")]), a.guard_band);
    EXPECT_EQ(std::stod(r[csv.Col("uncertainty")]), a.uncertainty);
    EXPECT_EQ(std::stod(r[csv.Col("high")]), high_);
  }
  EXPECT_TRUE(found);

  const std::string json = Imuqual("export --run " + a.run_id + " --as json");
  EXPECT_EQ(json.find("OUTCOME_UNSET"), std::string::npos);
  pb::RunRecords records;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(json, &records).ok());
  ASSERT_EQ(records.records_size(), 1);
  EXPECT_EQ(records.records(0).verdict(), pb::INCONCLUSIVE);
  found = false;
  for (const pb::Measurement& m : records.records(0).measurements()) {
    if (m.axis() != kAxis || m.name() != "bias_instability") continue;
    found = true;
    EXPECT_EQ(m.outcome(), pb::INCONCLUSIVE);
    EXPECT_EQ(m.decision_rule(), pb::Limit::GUARDED);
    EXPECT_EQ(m.guard_band(), a.guard_band);
  }
  EXPECT_TRUE(found);
  EXPECT_NE(json.find("\"outcome\": \"INCONCLUSIVE\""), std::string::npos);
  EXPECT_NE(json.find("\"decision_rule\": \"GUARDED\""), std::string::npos);
}

}  // namespace
}  // namespace imuqual
