// Early decisions at the station, over real LCM multicast (a private network
// namespace when ctest can make one, else a fresh port with ttl=0): a unit
// the analysis decides PASS or FAIL at a look has its source stopped by
// acquire and its run ended there, complete, "decided PASS at T s (early
// decision)"; every batch published up to the stop is archived (resends
// included), the archive holds the decision time and the evidence, and the
// re-analysis of the archive reaches the same decision at the same look. A
// unit still pending soaks its full length beside them. A long recording
// replayed from CSV with and without early decisions gets the same verdict,
// and the early run says when it was decided.
//
// The simulated and replayed units are deterministic (seeded), so which unit
// decides is known; the tests check what follows from a decision, not when
// the engine reaches it (analyze/judge/early_decision_test.cc does).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "acquire/imu_simulator.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/strings.h"
#include "common/text_util.h"
#include "imuqual/decision_t.hpp"
#include "store/archive.h"
#include "tests/archive_checks.h"
#include "tests/csv_table.h"
#include "tests/station_harness.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::ExpectSoakArchivedWhole;
using testing::RunCommand;
using testing::StationHarness;

constexpr double kRateHz = 100;
constexpr double kWarmupS = 60;
constexpr double kRunTimeoutS = 240;  // bound on a soak (each takes a few seconds)

// The station test's short-soak limits (no tau_at_minimum limit: resolving
// a 10-20 s minimum takes most of a 600 s record), decided at looks every
// 20 s from 60 s over the 600 s soak.
// clang-format off
constexpr char kSimPlan[] = R"pb(
name: "early-itest"
axes { name: "x" kind: GYRO }
axes { name: "y" kind: GYRO }
axes { name: "z" kind: GYRO }
nominal_rate_hz: 100
min_duration_s: 600
warmup_s: 60
grid { kind: OCTAVE }
limits { measurement: "bias_instability" axis_kind: GYRO high: 20 marginal_high: 16 unit: "deg/h" }
limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.6 marginal_high: 0.5 unit: "deg/sqrt(h)" }
limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
early_decision { risk: 0.01 min_duration_s: 60 look_period_s: 20 horizon_s: 600 }
)pb";
// clang-format on
constexpr double kSimHorizonS = 600;
constexpr int kSimLooks = 27;  // 60, 80, ..., 580 s

// Small batches and a small window: acquire runs at most 8 s of data ahead
// of the analysis, so a decided unit's source stops long before its end.
std::vector<std::string> AcquireArgs(const std::string& lot, const std::string& prefix,
                                     const std::string& plan) {
  return {
      "--lot",           lot,   "--run-prefix", prefix, "--plan", plan, "--await", "store,analyze",
      "--batch-samples", "100", "--window",     "8",    "--rate", "100"};
}

// As acquire and the analysis write times: %g.
std::string FormatG(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// As the exports and the report's data-v write values: shortest round-trip.
std::string Exact(double v) {
  return ShortestReal(v);
}

// One run as archived, with its early decision.
struct ArchivedRun {
  std::string run_id, serial, state, end_reason, verdict, reasons;
  int64_t samples_announced = 0;  // what acquire published per axis
  int64_t samples = 0;            // what the judgement analysed per axis
  bool has_decision_time = false;
  double decision_time_s = NAN;
  std::string decision_note;
  std::vector<std::string> notes;  // every measurement's note
};

std::map<std::string, ArchivedRun> ReadRuns(const std::string& db) {
  std::map<std::string, ArchivedRun> out;
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  EXPECT_TRUE(a.ok()) << a.status().ToString();
  if (!a.ok()) return out;
  auto s = (*a)->db().Prepare(
      "SELECT run_id, serial, state, end_reason, COALESCE(verdict, ''), COALESCE(reasons, ''), "
      "samples_announced, COALESCE(samples, 0), run_key FROM runs ORDER BY run_id");
  auto m = (*a)->db().Prepare("SELECT axis, name, value, note FROM measurements WHERE run_key = ?");
  EXPECT_TRUE(s.ok() && m.ok());
  while (*s->Step()) {
    ArchivedRun r;
    r.run_id = s->Text(0);
    r.serial = s->Text(1);
    r.state = s->Text(2);
    r.end_reason = s->Text(3);
    r.verdict = s->Text(4);
    r.reasons = s->Text(5);
    r.samples_announced = s->Int(6);
    r.samples = s->Int(7);
    m->Reset();
    m->Bind(1, s->Int(8));
    while (*m->Step()) {
      r.notes.push_back(m->Text(3));
      if (m->Text(0).empty() && m->Text(1) == "decision_time") {
        r.has_decision_time = true;
        r.decision_time_s = m->Real(2);
        r.decision_note = m->Text(3);
      }
    }
    out[r.run_id] = r;
  }
  return out;
}

// The run decided `word` ("PASS", "FAIL"): it ended complete with the
// decision as its end reason, the judgement analysed exactly the record up
// to the deciding look, acquire stopped before the full soak, and the
// archive holds more than was analysed (the tail it sent before stopping).
void ExpectDecided(const ArchivedRun& r, const std::string& word, double full_s) {
  SCOPED_TRACE(r.run_id);
  EXPECT_EQ(r.state, "complete") << r.reasons;
  ASSERT_TRUE(r.has_decision_time);
  ASSERT_TRUE(std::isfinite(r.decision_time_s)) << r.decision_note;
  EXPECT_EQ(r.end_reason,
            "decided " + word + " at " + FormatG(r.decision_time_s) + " s (early decision)");
  EXPECT_EQ(r.decision_note.rfind("decided " + word + " at look ", 0), 0u) << r.decision_note;
  EXPECT_EQ(r.samples, std::llround(r.decision_time_s * kRateHz));
  EXPECT_LT(r.samples_announced, std::llround((kWarmupS + full_s) * kRateHz))
      << "the source was not stopped";
  EXPECT_GE(r.samples_announced, std::llround(kWarmupS * kRateHz) + r.samples);
  // Each decided measurement says when and by which bound: at the unit's
  // decision or before it (a measurement may be decided looks before the
  // unit is).
  const std::string when = "decided " + word + " at ";
  int decided_notes = 0;
  for (const std::string& note : r.notes) {
    size_t at = note.find(when);  // after the value's own note, if it has one
    if (at == std::string::npos || note.find(" s (look ", at) == std::string::npos) continue;
    at += when.size();
    ++decided_notes;
    EXPECT_LE(std::stod(note.substr(at)), r.decision_time_s) << note;
  }
  EXPECT_GT(decided_notes, 0) << "no measurement note says " << when << "T s (look k)";
  if (word == "FAIL") {
    EXPECT_EQ(r.verdict, "FAIL");
    EXPECT_NE(r.reasons.find("decided FAIL at "), std::string::npos) << r.reasons;
  } else {
    EXPECT_TRUE(r.verdict == "PASS" || r.verdict == "MARGINAL") << r.verdict;
  }
}

// GIVEN a clearly good unit, the lot's planted failure and a planted failure
// too near its limit for any look to decide, soaked together under a plan
// with early decisions, one batch in twenty lost on its first publication
TEST(EarlyDecisionTest, DecidedUnitsEndAtTheirDecisionAndArchiveCleanly) {
  StationHarness h("early_sim");
  const std::string plan = h.path("plan.textproto");
  std::ofstream(plan) << kSimPlan;
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  std::map<std::string, std::vector<imuqual::decision_t>> heard;  // run id -> decision_t
  h.bus().Subscribe<imuqual::decision_t>(
      channels::kDecisionAll, 10000,
      [&heard](const std::string&, imuqual::decision_t&& d, int64_t) {
        heard[d.run_id].push_back(std::move(d));
      });
  std::vector<std::string> args = AcquireArgs("EARLY", "SIM", plan);
  // Lot seed 2: unit 1 is a good one, unit 7 the planted failure; under the
  // lot's own seed (from "EARLY") the planted unit lies near 20 deg/h.
  args.insert(args.end(), {"--duration", "660", "--inject-drop", "0.05", "--inject-seed", "3",
                           "--unit", "GOOD=sim:vg700,index=1,seed=2", "--unit",
                           "BAD=sim:vg700,index=7,seed=2", "--unit", "SLOW=sim:vg700,index=7"});
  Subprocess acquire = h.Start("imuqual-acquire", args);
  ASSERT_TRUE(h.WaitRunsDone(3, kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(acquire.Wait(30), 0) << h.Logs();

  // THEN the good unit and the failure were decided and their sources
  // stopped there; the third soaked its full length.
  const auto runs = ReadRuns(h.db());
  ASSERT_EQ(runs.size(), 3u);
  const ArchivedRun& good = runs.at("SIM-GOOD");
  const ArchivedRun& bad = runs.at("SIM-BAD");
  const ArchivedRun& slow = runs.at("SIM-SLOW");
  ExpectDecided(good, "PASS", kSimHorizonS);
  ExpectDecided(bad, "FAIL", kSimHorizonS);
  EXPECT_EQ(slow.state, "complete");
  EXPECT_EQ(slow.end_reason, "");
  EXPECT_EQ(slow.samples_announced, std::llround((kWarmupS + kSimHorizonS) * kRateHz));
  EXPECT_EQ(slow.samples, std::llround(kSimHorizonS * kRateHz));
  ASSERT_TRUE(slow.has_decision_time);
  EXPECT_TRUE(std::isnan(slow.decision_time_s));
  EXPECT_EQ(slow.decision_note.rfind(
                "pending at every one of " + std::to_string(kSimLooks) + " looks", 0),
            0u)
      << slow.decision_note;
  EXPECT_EQ(slow.verdict, "FAIL");  // the full-length verdict
  // AND the analysis said so on the bus: a PENDING state after every look
  // before the decision, then the decision, with the device counter where
  // its analysis stopped (a simulated unit counts from 0).
  for (const ArchivedRun* r : {&good, &bad}) {
    SCOPED_TRACE(r->run_id);
    const auto& messages = heard[r->run_id];
    ASSERT_FALSE(messages.empty());
    const imuqual::decision_t& last = messages.back();
    EXPECT_EQ(last.state,
              r == &good ? imuqual::decision_t::STATE_PASS : imuqual::decision_t::STATE_FAIL);
    EXPECT_EQ(last.decided_at_s, r->decision_time_s);
    EXPECT_EQ(last.end_sample, std::llround((kWarmupS + r->decision_time_s) * kRateHz));
    EXPECT_EQ(last.looks_planned, kSimLooks);
    const int deciding_look = static_cast<int>(std::lround((r->decision_time_s - 60) / 20)) + 1;
    EXPECT_EQ(last.looks_done, deciding_look);
    EXPECT_TRUE(std::isfinite(last.z) && last.z > 0) << last.z;
    EXPECT_EQ(last.revision, 0);
    std::set<int> pending_looks;
    for (const imuqual::decision_t& d : messages) {
      if (d.state == imuqual::decision_t::STATE_PENDING) pending_looks.insert(d.looks_done);
    }
    EXPECT_EQ(pending_looks.size(), static_cast<size_t>(deciding_look - 1));
  }
  {
    const auto& messages = heard["SIM-SLOW"];
    ASSERT_FALSE(messages.empty());
    const imuqual::decision_t& last = messages.back();
    EXPECT_EQ(last.state, imuqual::decision_t::STATE_PENDING);
    EXPECT_EQ(last.looks_done, kSimLooks);
    ASSERT_GT(last.num_pending, 0);
    for (const std::string& why : last.pending) {
      EXPECT_TRUE(why.starts_with("x: ") || why.starts_with("y: ") || why.starts_with("z: "))
          << why;
    }
  }
  // AND both sides counted it: not vacuous.
  EXPECT_EQ(h.WaitCounter("acquire", "runs_decided", 2, 10), 2);
  EXPECT_EQ(h.WaitCounter("analyze", "runs_decided", 2, 10), 2);
  EXPECT_GT(h.Counter("analyze", "decisions_published"), 2 * 2);
  EXPECT_GT(h.Counter("acquire", "injected_drops"), 0);
  EXPECT_GT(h.Counter("acquire", "batches_resent"), 0);

  // AND every run is archived whole (every batch published, the tail after
  // a decision included, no gap), and `imuqual reanalyze --check` on the
  // archive reaches the same judgement, decision and decision time bit for
  // bit.
  ExpectSoakArchivedWhole(h.db(), 3, 3);
  // AND every look's evidence comes back from the archive: `reanalyze
  // --looks` lists each look up to the decision (the good unit's) or to the
  // end (the slow one's), every judged measurement's value and decision, and
  // the unit's state after each look, agreeing with the decision archived.
  for (const ArchivedRun* r : {&good, &slow}) {
    SCOPED_TRACE(r->run_id);
    const auto looks = RunCommand(Bin("imuqual") + " reanalyze " + r->run_id + " --db " +
                                  h.db() + " --looks --format csv");
    ASSERT_EQ(looks.exit_code, 0) << looks.output;
    const testing::Csv t = testing::ParseCsv(looks.output);
    const int expected_looks =
        r == &good ? static_cast<int>(std::lround((r->decision_time_s - 60) / 20)) + 1 : kSimLooks;
    int unit_rows = 0, measurement_rows = 0;
    std::string last_unit;
    for (const auto& row : t.rows) {
      if (row[t.Col("axis")] == "*") {
        ++unit_rows;
        EXPECT_EQ(std::stoi(row[t.Col("look")]), unit_rows);
        last_unit = row[t.Col("decision")];
      } else {
        ++measurement_rows;
        const std::string d = row[t.Col("decision")];
        EXPECT_TRUE(d == "PASS" || d == "FAIL" || d == "PENDING") << d;
        EXPECT_FALSE(row[t.Col("why")].empty()) << row[t.Col("measurement")];
      }
    }
    EXPECT_EQ(unit_rows, expected_looks);
    EXPECT_EQ(measurement_rows, 3 * 2 * expected_looks);  // BI and ARW per axis and look
    EXPECT_EQ(last_unit, r == &good ? "PASS" : "PENDING");
  }
  // An unknown run: an error, not an empty table.
  {
    const auto none = RunCommand(Bin("imuqual") + " reanalyze NO-SUCH-RUN --db " + h.db() +
                                 " --looks");
    EXPECT_NE(none.exit_code, 0);
  }

  // AND the lot's table says when each unit was decided, and the soak time
  // the decisions saved: horizon - decision time over the decided runs.
  const double saved_s =
      (kSimHorizonS - good.decision_time_s) + (kSimHorizonS - bad.decision_time_s);
  const auto table = RunCommand(Bin("imuqual") + " lot EARLY --db " + h.db());
  ASSERT_EQ(table.exit_code, 0) << table.output;
  EXPECT_NE(table.output.find("decided at"), std::string::npos) << table.output;
  EXPECT_NE(table.output.find("full soak"), std::string::npos) << table.output;
  EXPECT_NE(table.output.find("early decisions: 2 of 3 runs decided"), std::string::npos)
      << table.output;
  EXPECT_NE(table.output.find("soak time saved " + FormatG(saved_s) + " s"), std::string::npos)
      << table.output;
  const auto csv = RunCommand(Bin("imuqual") + " lot EARLY --db " + h.db() + " --format csv");
  ASSERT_EQ(csv.exit_code, 0);
  const testing::Csv t = testing::ParseCsv(csv.output);
  ASSERT_FALSE(t.rows.empty()) << csv.output;
  int checked = 0;
  for (size_t i = 0; i < t.rows.size(); ++i) {
    const std::string unit = t.rows[i][t.Col("serial")], cell = t.rows[i][t.Col("decision_time_s")];
    if (unit == "GOOD") {
      EXPECT_EQ(cell, Exact(good.decision_time_s));
    } else if (unit == "SLOW") {
      EXPECT_EQ(cell, "");
    }
    checked += unit == "GOOD" || unit == "SLOW";
  }
  EXPECT_EQ(checked, 6);  // 3 axes each
  // AND so does the report, per unit and for the lot.
  const std::string html = h.path("report.html");
  ASSERT_EQ(
      RunCommand(Bin("imuqual") + " report --db " + h.db() + " --lot EARLY -o " + html).exit_code,
      0);
  auto page = ReadFileToString(html);
  ASSERT_TRUE(page.ok());
  EXPECT_NE(page->find("<section id=\"early-decisions\""), std::string::npos);
  EXPECT_NE(page->find("data-field=\"soak_saved_s\" data-v=\"" + Exact(saved_s) + "\""),
            std::string::npos);
  EXPECT_NE(
      page->find("data-run=\"SIM-BAD\" data-decision-time=\"" + Exact(bad.decision_time_s) + "\""),
      std::string::npos);
}

// A recorded unit: three gyro axes of a tactical part (ARW 0.36 deg/sqrt(h),
// bias instability ~5 deg/h), `rows` rows at 100 Hz, written as CSV with a
// device counter.
void WriteRecording(const std::string& path, int rows) {
  pb::SimTruth truth;
  truth.set_seed(41);
  truth.set_actual_rate_hz(kRateHz);
  for (const char* name : {"gx", "gy", "gz"}) {
    pb::AxisTruth* a = truth.add_axes();
    a->set_axis(name);
    a->set_random_walk(0.006);
    a->set_bias_instability(8.0 / 3600);
    a->set_rate_random_walk(2e-4);
    a->set_bias(0.1);
  }
  auto sim = sim::ImuSimulator::Create(truth);
  ASSERT_TRUE(sim.ok()) << sim.status().ToString();
  std::vector<std::vector<float>> y(3);
  sim->Generate(rows, y);
  std::ofstream csv(path);
  csv << "count,gx,gy,gz\n";
  char line[128];
  for (int k = 0; k < rows; ++k) {
    std::snprintf(line, sizeof line, "%d,%.9g,%.9g,%.9g\n", 500 + k, y[0][k], y[1][k], y[2][k]);
    csv << line;
  }
}

// clang-format off
constexpr char kCsvPlan[] = R"pb(
name: "csv-itest"
axes { name: "gx" kind: GYRO }
axes { name: "gy" kind: GYRO }
axes { name: "gz" kind: GYRO }
nominal_rate_hz: 100
min_duration_s: 1200
warmup_s: 60
grid { kind: OCTAVE }
limits { measurement: "bias_instability" axis_kind: GYRO high: 20 marginal_high: 16 unit: "deg/h" }
limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.6 marginal_high: 0.5 unit: "deg/sqrt(h)" }
limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
)pb";
// clang-format on
constexpr double kCsvSoakS = 1200;
// Looks every 30 s from 60 s; the horizon is the plan's 1200 s soak.
constexpr char kCsvEarly[] = "early_decision { risk: 0.01 min_duration_s: 60 look_period_s: 30 }\n";

// GIVEN a 21-minute recording of one unit, replayed from CSV through the
// station twice: under the plan, and under the plan with early decisions
TEST(EarlyDecisionTest, ReplayedRecordingGetsTheSameVerdictAndSaysWhenItWasDecided) {
  StationHarness h("early_csv");
  const int rows = static_cast<int>((kWarmupS + kCsvSoakS) * kRateHz);
  const std::string csv = h.path("unit.csv");
  WriteRecording(csv, rows);
  const std::string full_plan = h.path("full.textproto"), early_plan = h.path("early.textproto");
  std::ofstream(full_plan) << kCsvPlan;
  std::ofstream(early_plan) << kCsvPlan << kCsvEarly;
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  const std::string source =
      "R1=csv:" + csv + ",rate=100,counter=count,axes=gx:gyro/gy:gyro/gz:gyro";
  int64_t forged_ignored = -1;
  for (const auto& [prefix, plan] :
       {std::pair<std::string, std::string>{"FULL", full_plan}, {"EARLY", early_plan}}) {
    std::vector<std::string> args = AcquireArgs("CSV", prefix, plan);
    args.insert(args.end(), {"--unit", source});
    Subprocess acquire = h.Start("imuqual-acquire", args);
    const size_t done = prefix == "FULL" ? 1 : 2;
    if (prefix == "FULL") {
      // A decision for a run whose plan has no early_decision (none is ever
      // sent; here forged) stops nothing.
      imuqual::decision_t forged{};
      forged.run_id = "FULL-R1";
      forged.unit_serial = "R1";
      forged.state = imuqual::decision_t::STATE_PASS;
      forged.decided_at_s = 60;
      const double end = MonotonicSeconds() + kRunTimeoutS;
      while (!h.WaitRunsDone(done, 0.2) && MonotonicSeconds() < end) {
        forged.host_utime = NowUtime();
        ASSERT_TRUE(h.BusAs(BusRole::kAnalyze).Publish(channels::Decision("R1"), forged).ok());
      }
    }
    ASSERT_TRUE(h.WaitRunsDone(done, kRunTimeoutS)) << h.Logs();
    EXPECT_EQ(acquire.Wait(30), 0) << h.Logs();
    if (prefix == "FULL") {
      h.Pump(300);  // acquire's last status
      forged_ignored = h.CounterOf(acquire.pid(), "decisions_ignored");
    }
  }
  EXPECT_GT(forged_ignored, 0) << "the forged decisions never reached acquire: the test is vacuous";
  const auto runs = ReadRuns(h.db());
  ASSERT_EQ(runs.size(), 2u);
  const ArchivedRun& full = runs.at("FULL-R1");
  const ArchivedRun& early = runs.at("EARLY-R1");
  // THEN the full replay soaked every row, and has no decision at all
  EXPECT_EQ(full.end_reason, "");
  EXPECT_EQ(full.samples_announced, rows);
  EXPECT_EQ(full.samples, std::llround(kCsvSoakS * kRateHz));
  EXPECT_FALSE(full.has_decision_time);
  // AND the early one was decided and stopped at its decision, with the same
  // verdict as the full-length soak.
  ASSERT_TRUE(full.verdict == "PASS" || full.verdict == "MARGINAL") << full.reasons;
  ExpectDecided(early, "PASS", kCsvSoakS);
  EXPECT_EQ(early.verdict, full.verdict)
      << "early: " << early.reasons << "\nfull: " << full.reasons;
  // AND both are archived whole and re-analyse bit for bit.
  ExpectSoakArchivedWhole(h.db(), 2, 3);
  // AND the unit's history says when the early run was decided, and that
  // the other had no early decisions.
  const auto listing = RunCommand(Bin("imuqual") + " unit R1 --db " + h.db() + " --format csv");
  ASSERT_EQ(listing.exit_code, 0) << listing.output;
  const testing::Csv t = testing::ParseCsv(listing.output);
  ASSERT_EQ(t.rows.size(), 6u) << listing.output;  // 2 runs x 3 axes
  for (const std::vector<std::string>& row : t.rows) {
    const bool is_early = row[t.Col("run_id")] == "EARLY-R1";
    EXPECT_EQ(row[t.Col("decision_time_s")], is_early ? Exact(early.decision_time_s) : "");
  }
  const auto table = RunCommand(Bin("imuqual") + " unit R1 --db " + h.db());
  ASSERT_EQ(table.exit_code, 0);
  EXPECT_NE(table.output.find("decided at"), std::string::npos) << table.output;
}

}  // namespace
}  // namespace imuqual
