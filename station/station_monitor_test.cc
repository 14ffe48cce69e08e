#include "station/station_monitor.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/channels.h"
#include "imuqual/measurement_t.hpp"
#include "imuqual/plan.pb.h"
#include "imuqual/rate_batch_t.hpp"

namespace imuqual::station {
namespace {

imuqual::run_t RunMsg(const std::string& run_id, const std::string& serial, const std::string& slot,
                      int8_t state = imuqual::run_t::STATE_RUNNING, int64_t samples = 1000,
                      int64_t start_utime = 1'000'000) {
  imuqual::run_t r{};
  r.run_id = run_id;
  r.unit_serial = serial;
  r.slot = slot;
  r.lot = "L1";
  r.station = "bench-A";
  r.source = "sim:vg700";
  r.announcer = "acquire";
  r.nominal_rate_hz = 100;
  r.state = state;
  r.samples_published = samples;
  r.start_utime = start_utime;
  r.num_axes = 2;
  r.axis_names = {"gx", "gy"};
  r.axis_kinds = {imuqual::rate_batch_t::KIND_GYRO, imuqual::rate_batch_t::KIND_GYRO};
  return r;
}

imuqual::status_t StatusMsg(const std::string& process, const std::string& instance,
                            bool healthy = true, const std::string& message = "") {
  imuqual::status_t s{};
  s.process = process;
  s.instance = instance;
  s.healthy = healthy;
  s.message = message;
  return s;
}

imuqual::unit_result_t ResultMsg(const std::string& run_id, const std::string& serial, bool final,
                                 double gx_bi, int8_t gx_outcome) {
  imuqual::unit_result_t r{};
  r.run_id = run_id;
  r.unit_serial = serial;
  r.is_final = final;
  r.host_utime = 77;
  r.verdict = final ? gx_outcome : 0;
  imuqual::measurement_t m{};
  m.axis = "gx";
  m.name = "bias_instability";
  m.value = gx_bi;
  m.unit = "deg/h";
  m.uncertainty = 0.5;
  m.low = std::nan("");  // as the analysis publishes an absent bound
  m.high = 10;
  m.marginal_low = std::nan("");
  m.marginal_high = std::nan("");
  m.outcome = gx_outcome;
  r.measurements.push_back(m);
  r.num_measurements = 1;
  if (final) {
    r.reasons = {"gx: bias_instability 12 deg/h > 10"};
    r.num_reasons = 1;
  }
  return r;
}

// A monitor that discovers units and keeps curves, with run R-U1 (unit U1,
// axes gx and gy) announced.
StationMonitor CurveMonitor() {
  MonitorOptions o;
  o.discover_units = true;
  o.keep_curves = true;
  StationMonitor m(o);
  m.OnRun(RunMsg("R-U1", "U1", "A1"));
  return m;
}

// A gyro curve of R-U1's `axis`: dev = 1e-3 / sqrt(tau) deg/s at the `n`
// taus 0.01, 0.02, ... s, +-10 %.
imuqual::allan_curve_t Curve(const std::string& axis, int n) {
  imuqual::allan_curve_t c{};
  c.run_id = "R-U1";
  c.unit_serial = "U1";
  c.axis = axis;
  c.axis_kind = imuqual::rate_batch_t::KIND_GYRO;
  c.estimator = "oadev";
  c.samples = 5000;
  c.host_utime = 99;
  for (int i = 0; i < n; ++i) {
    const double tau = 0.01 * (i + 1);
    c.m.push_back(i + 1);
    c.tau_s.push_back(tau);
    c.dev.push_back(1e-3 / std::sqrt(tau));
    c.lo.push_back(0.9e-3 / std::sqrt(tau));
    c.hi.push_back(1.1e-3 / std::sqrt(tau));
  }
  c.num_points = n;
  return c;
}

// Run R-U1 of unit U1 on a serial line.
imuqual::run_t SerialRun() {
  imuqual::run_t r = RunMsg("R-U1", "U1", "A1");
  r.source = "serial:/dev/ttyUSB0,protocol=text";
  return r;
}

// A discovering monitor that heard `r` and was refreshed at 10 s.
StationMonitor MonitorOf(const imuqual::run_t& r) {
  MonitorOptions o;
  o.discover_units = true;
  StationMonitor m(o);
  m.OnRun(r);
  m.Refresh(10.0, false);
  return m;
}

TEST(StationMonitorTest, DiscoversUnitsInSlotOrderAndTakesTheHeaderFromTheirRuns) {
  MonitorOptions o;
  o.discover_units = true;
  StationMonitor m(o);
  m.OnRun(RunMsg("R-U10", "U10", "A10"));
  m.OnRun(RunMsg("R-U2", "U2", "A2"));
  m.OnRun(RunMsg("R-U1", "U1", "A1"));
  ASSERT_EQ(m.model().units.size(), 3u);
  EXPECT_EQ(m.model().units[0].serial, "U1");
  EXPECT_EQ(m.model().units[1].serial, "U2");  // A2 before A10
  EXPECT_EQ(m.model().units[2].serial, "U10");
  EXPECT_EQ(m.model().station, "bench-A");
  EXPECT_EQ(m.model().lot, "L1");
  EXPECT_DOUBLE_EQ(m.model().units[1].elapsed_s, 10.0);
  ASSERT_EQ(m.model().units[1].axes.size(), 2u);
  // A result or decision of an unknown unit adds nothing: it names no slot.
  m.OnResult(ResultMsg("R-U9", "U9", false, 3, imuqual::measurement_t::OUTCOME_PASS));
  EXPECT_EQ(m.model().units.size(), 3u);
}

// Progress and "elapsed / planned" from each run's announced plan: the live
// page (which knows no station duration) reads as the console does; a
// store's re-announcement (planned 0) keeps what acquire said.
TEST(StationMonitorTest, ProgressFromTheAnnouncedPlannedLength) {
  MonitorOptions o;
  o.discover_units = true;
  StationMonitor m(o);
  EXPECT_EQ(ConsoleProgress(m.model()), 0.0);
  imuqual::run_t a = RunMsg("R-U1", "U1", "A1", imuqual::run_t::STATE_RUNNING, 30000);
  a.planned_s = 600;  // 300 s of 600 published
  imuqual::run_t b = RunMsg("R-U2", "U2", "A2", imuqual::run_t::STATE_RUNNING, 6000);
  b.planned_s = 600;  // 60 s of 600
  m.OnRun(a);
  m.OnRun(b);
  EXPECT_NEAR(ConsoleProgress(m.model()), (0.5 + 0.1) / 2, 1e-12);
  EXPECT_EQ(DescribeUnit(m.model(), m.model().units[0]).elapsed, "5:00 / 10:00");
  imuqual::run_t again = b;
  again.announcer = "store";
  again.planned_s = 0;
  m.OnRun(again);
  EXPECT_EQ(m.model().units[1].planned_s, 600.0);
  // A unit whose length is not known counts as not begun, not as done.
  imuqual::run_t c = RunMsg("R-U3", "U3", "A3", imuqual::run_t::STATE_RUNNING, 6000);
  m.OnRun(c);
  EXPECT_NEAR(ConsoleProgress(m.model()), (0.5 + 0.1 + 0) / 3, 1e-12);
}

TEST(StationMonitorTest, WithoutDiscoveryOnlyItsUnitsAndItsRunPrefix) {
  MonitorOptions o;
  o.run_prefix = "P1";
  StationMonitor m(o);
  m.AddUnit("1", "U1");
  m.OnRun(RunMsg("P0-U1", "U1", "9"));  // another station run
  m.OnRun(RunMsg("P1-U7", "U7", "7"));  // not this station's unit
  ASSERT_EQ(m.model().units.size(), 1u);
  EXPECT_TRUE(m.model().units[0].run_id.empty());
  m.OnRun(RunMsg("P1-U1", "U1", "1"));
  EXPECT_EQ(m.model().units[0].run_id, "P1-U1");
}

TEST(StationMonitorTest, ANewerRunOfAUnitReplacesItsRow) {
  MonitorOptions o;
  o.discover_units = true;
  StationMonitor m(o);
  m.OnRun(RunMsg("R1-U1", "U1", "A1", imuqual::run_t::STATE_COMPLETE, 5000, 1'000'000));
  m.OnResult(ResultMsg("R1-U1", "U1", true, 12, imuqual::measurement_t::OUTCOME_FAIL));
  EXPECT_TRUE(m.model().units[0].final_result);
  // An older run's late message changes nothing.
  m.OnRun(RunMsg("R0-U1", "U1", "A1", imuqual::run_t::STATE_RUNNING, 10, 500'000));
  EXPECT_EQ(m.model().units[0].run_id, "R1-U1");
  m.OnRun(RunMsg("R2-U1", "U1", "A1", imuqual::run_t::STATE_RUNNING, 100, 2'000'000));
  ASSERT_EQ(m.model().units.size(), 1u);
  EXPECT_EQ(m.model().units[0].run_id, "R2-U1");
  EXPECT_FALSE(m.model().units[0].final_result);
  EXPECT_EQ(m.model().units[0].samples, 100);
}

void Finish(StationMonitor& m, const std::string& run_id, const std::string& serial) {
  m.OnResult(ResultMsg(run_id, serial, true, 5, imuqual::measurement_t::OUTCOME_PASS));
  imuqual::ack_t a{};
  a.process = "store";
  a.num_runs = 1;
  a.run_ids = {run_id};
  a.next_seq = {0};
  a.run_done = {true};
  m.OnAck(a);
}

// A discovering monitor: a store heard at 0 s, units A (slot 1) and B (slot
// 2) running in soak S1, A finished.
StationMonitor SoakWithAFinished() {
  MonitorOptions o;
  o.discover_units = true;
  StationMonitor m(o);
  m.OnStatus(StatusMsg("store", "h:1"), 0);
  m.OnRun(RunMsg("S1-A", "A", "1", imuqual::run_t::STATE_RUNNING, 10, 1000));
  m.OnRun(RunMsg("S1-B", "B", "2", imuqual::run_t::STATE_RUNNING, 10, 1000));
  Finish(m, "S1-A", "A");
  return m;
}

TEST(StationMonitorTest, ANewSoakReplacesTheDoneOneAndItsProcesses) {
  StationMonitor m = SoakWithAFinished();
  // Not all done: a new unit in another slot is added beside them.
  m.OnRun(RunMsg("S2-C", "C", "3", imuqual::run_t::STATE_RUNNING, 10, 2000));
  EXPECT_EQ(m.model().units.size(), 3u);
  // A new unit in slot 1, whose unit is done, takes its row.
  m.OnRun(RunMsg("S2-D", "D", "1", imuqual::run_t::STATE_RUNNING, 10, 2000));
  ASSERT_EQ(m.model().units.size(), 3u);
  EXPECT_EQ(m.model().units[0].serial, "D");
  Finish(m, "S1-B", "B");
  Finish(m, "S2-C", "C");
  Finish(m, "S2-D", "D");
  // The station's processes end; a new soak's start anew: no restart.
  m.Refresh(10, true);
  m.OnStatus(StatusMsg("store", "h:2"), 20);
  m.Refresh(20, true);
  EXPECT_EQ(m.model().processes[0].restarts, 1);  // as far as it can tell yet
  m.OnRun(RunMsg("S3-E", "E", "1", imuqual::run_t::STATE_RUNNING, 10, 3000));
  ASSERT_EQ(m.model().units.size(), 1u);
  EXPECT_EQ(m.model().units[0].serial, "E");
  m.OnStatus(StatusMsg("store", "h:2"), 21);  // the running store reports again
  m.Refresh(21, true);
  EXPECT_EQ(m.model().processes[0].restarts, 0);
  EXPECT_EQ(m.model().processes[0].running, 1);
  // The store re-announcing an old run does not bring it back as a new soak.
  imuqual::run_t old = RunMsg("S1-A", "A", "1", imuqual::run_t::STATE_COMPLETE, 10, 1000);
  old.announcer = "store";
  m.OnRun(old);
  EXPECT_EQ(m.model().units.size(), 2u);  // shown (its analysis is not finished), E kept
  EXPECT_EQ(m.model().units[1].serial, "E");
}

TEST(StationMonitorTest, TheSameUnitsSoakedAgainStartANewSoak) {
  StationMonitor m = SoakWithAFinished();
  Finish(m, "S1-B", "B");
  m.Refresh(1, true);
  // The station's store exits 2 s before the next soak's first run; the
  // next soak's store reports after it.
  m.OnStatus(StatusMsg("store", "h:2"), 3.5);
  m.OnRun(RunMsg("S2-A", "A", "1", imuqual::run_t::STATE_RUNNING, 10, 2000));
  m.OnStatus(StatusMsg("store", "h:2"), 4);
  m.Refresh(4, true);
  ASSERT_EQ(m.model().units.size(), 1u);  // B left with the last soak
  EXPECT_EQ(m.model().units[0].run_id, "S2-A");
  EXPECT_EQ(m.model().processes[0].restarts, 0);
  EXPECT_EQ(m.model().processes[0].running, 1);
  m.Refresh(10, true);
  EXPECT_EQ(m.model().processes[0].restarts, 0);
}

TEST(StationMonitorTest, AQuickRestartIsOneProcessExpected) {
  StationMonitor m;
  // A store restarted at once (no delay): its successor is heard within a
  // status period of its last word, so for a few seconds both look alive.
  for (double t = 0; t <= 2; t += 1) m.OnStatus(StatusMsg("store", "h:1"), t);
  for (double t = 2.5; t <= 12; t += 1) {
    m.OnStatus(StatusMsg("store", "h:2"), t);
    m.Refresh(t + 0.1, true);
  }
  EXPECT_EQ(m.model().processes[0].running, 1);
  EXPECT_EQ(m.model().processes[0].expected, 1);
  EXPECT_EQ(m.model().processes[0].restarts, 1);
  EXPECT_NE(ConsoleProcessesLine(m.model()).find("store up (restarted 1x)"), std::string::npos);
  // Forgotten after long silence, the restart still counts.
  for (double t = 13; t <= 700; t += 1) m.OnStatus(StatusMsg("store", "h:2"), t);
  m.Refresh(700.5, true);
  EXPECT_EQ(m.model().processes[0].restarts, 1);
}

TEST(StationMonitorTest, ReconnectingIsHeardFromEachAcquireProcess) {
  imuqual::run_t r = SerialRun();
  StationMonitor m = MonitorOf(r);
  imuqual::status_t a = StatusMsg("acquire", "h:1");
  a.counter_names = {std::string(channels::kReconnectingCounterPrefix) + "R-U1"};
  a.counter_values = {1};
  a.num_counters = 1;
  const imuqual::status_t b = StatusMsg("acquire", "h:2");  // another station's acquire
  for (double t = 11; t <= 20; t += 0.5) {
    m.OnStatus(a, t);
    m.OnStatus(b, t + 0.1);
    m.Refresh(t + 0.2, false);
    EXPECT_TRUE(m.model().units[0].reconnecting) << t;
  }
}

TEST(StationMonitorTest, CurvesOnlyForTheRunsAxes) {
  StationMonitor m = CurveMonitor();
  imuqual::allan_curve_t c = Curve("gx", 1);
  c.axis = "not-an-axis";
  m.OnCurve(c);
  EXPECT_TRUE(m.Curves(m.model().units[0]).empty());
  c.axis = "gx";
  for (int i = 0; i < 10; ++i) {
    c.estimator = "e" + std::to_string(i);
    m.OnCurve(c);
  }
  ASSERT_EQ(m.Curves(m.model().units[0]).size(), 1u);
  EXPECT_EQ(m.Curves(m.model().units[0])[0].estimator, "e0");
}

TEST(StationMonitorTest, ForgetsUnitsArchivedLongAgo) {
  MonitorOptions o;
  o.discover_units = true;
  o.forget_after_s = 60;
  StationMonitor m(o);
  m.OnRun(RunMsg("R-U1", "U1", "A1"));
  m.OnRun(RunMsg("R-U2", "U2", "A2"));
  m.OnResult(ResultMsg("R-U1", "U1", true, 12, imuqual::measurement_t::OUTCOME_FAIL));
  imuqual::ack_t a{};
  a.process = "store";
  a.num_runs = 1;
  a.run_ids = {"R-U1"};
  a.next_seq = {0};
  a.run_done = {true};
  m.OnAck(a);
  m.Refresh(100, true);
  m.Refresh(150, true);
  EXPECT_EQ(m.model().units.size(), 2u);
  m.Refresh(161, true);
  ASSERT_EQ(m.model().units.size(), 1u);
  EXPECT_EQ(m.model().units[0].serial, "U2");
  m.OnRun(RunMsg("R-U2", "U2", "A2", imuqual::run_t::STATE_RUNNING, 2000));
  EXPECT_EQ(m.model().units[0].samples, 2000);
}

TEST(StationMonitorTest, ResultsSetProvisionalAndFinalVerdictsAndRaiseTheVersion) {
  MonitorOptions o;
  o.discover_units = true;
  StationMonitor m(o);
  m.OnRun(RunMsg("R-U1", "U1", "A1"));
  const uint64_t before = m.version();
  m.OnResult(ResultMsg("R-U1", "U1", false, 12, imuqual::measurement_t::OUTCOME_FAIL));
  EXPECT_GT(m.version(), before);
  EXPECT_EQ(m.newest_utime(), 77);
  const ConsoleUnit& u = m.model().units[0];
  EXPECT_FALSE(u.final_result);
  EXPECT_EQ(u.verdict, imuqual::measurement_t::OUTCOME_FAIL);
  EXPECT_EQ(u.reason, "gx: bias_instability 12.00 \u00b1 0.50 deg/h, limit <= 10");
  ConsoleUnitCells cells = DescribeUnit(m.model(), u);
  EXPECT_EQ(cells.verdict, "fail?");
  ASSERT_EQ(cells.axes.size(), 2u);
  EXPECT_EQ(cells.axes[0].bias_instability, "12.00 \u00b1 0.50 deg/h");
  EXPECT_EQ(cells.axes[1].bias_instability, "-");
  // Each axis's invalid samples so far, from the result's per-axis counts.
  imuqual::unit_result_t bad =
      ResultMsg("R-U1", "U1", false, 12, imuqual::measurement_t::OUTCOME_FAIL);
  bad.num_axes = 2;
  bad.axis_invalid_samples = {0, 41};
  m.OnResult(bad);
  cells = DescribeUnit(m.model(), m.model().units[0]);
  EXPECT_EQ(cells.axes[0].invalid_samples, 0);
  EXPECT_EQ(cells.axes[1].invalid_samples, 41);
  // A value that can still change side: "pending", and why, with the limit.
  imuqual::unit_result_t pending =
      ResultMsg("R-U1", "U1", false, 10.4, imuqual::measurement_t::OUTCOME_INCONCLUSIVE);
  pending.measurements[0].qualifier = imuqual::measurement_t::QUALIFIER_MINIMUM_NOT_RESOLVED;
  m.OnResult(pending);
  EXPECT_EQ(DescribeUnit(m.model(), m.model().units[0]).verdict, "pending");
  EXPECT_EQ(m.model().units[0].reason,
            "pending: gx: bias_instability 10.40 \u00b1 0.50 deg/h (minimum not resolved yet), "
            "limit <= 10");
  m.OnResult(ResultMsg("R-U1", "U1", true, 12, imuqual::measurement_t::OUTCOME_FAIL));
  EXPECT_EQ(DescribeUnit(m.model(), m.model().units[0]).verdict, "FAIL");
  // A provisional result after the final one is ignored.
  m.OnResult(ResultMsg("R-U1", "U1", false, 3, imuqual::measurement_t::OUTCOME_PASS));
  EXPECT_TRUE(m.model().units[0].final_result);
  imuqual::ack_t a{};
  a.process = "store";
  a.num_runs = 1;
  a.run_ids = {"R-U1"};
  a.next_seq = {0};
  a.run_done = {true};
  m.OnAck(a);
  EXPECT_TRUE(m.RunArchived("R-U1"));
  EXPECT_EQ(DescribeUnit(m.model(), m.model().units[0]).state, "done");
}

TEST(StationMonitorTest, ProcessesFromStatusCountAliveAndRestartedInstances) {
  StationMonitor m;
  m.OnStatus(StatusMsg("store", "h:100"), 0.0);
  m.OnStatus(StatusMsg("analyze", "h:101"), 0.0);
  m.OnStatus(StatusMsg("analyze", "h:102"), 0.0);
  m.OnStatus(StatusMsg("acquire", "h:103"), 0.1);
  m.Refresh(1.0, true);
  ASSERT_EQ(m.model().processes.size(), 3u);
  EXPECT_EQ(m.model().processes[0].running, 1);
  EXPECT_EQ(m.model().processes[1].running, 2);
  EXPECT_EQ(m.model().processes[1].expected, 2);
  EXPECT_TRUE(m.Reported("analyze", 102));
  EXPECT_FALSE(m.Reported("store", 102));
  // The store killed at 1.5 s (last heard at 1 s), a new one reports at
  // 2.6 s: while the old one is not yet known gone, one store is expected,
  // one runs, one was restarted. The others go on.
  m.OnStatus(StatusMsg("store", "h:100"), 1.0);
  for (double t = 1.0; t <= 8.0; t += 0.5) {
    m.OnStatus(StatusMsg("analyze", "h:101"), t);
    m.OnStatus(StatusMsg("analyze", "h:102"), t + 0.3);
    m.OnStatus(StatusMsg("acquire", "h:103", false, "unit U3: device gone"), t);
    if (t >= 2.5) m.OnStatus(StatusMsg("store", "h:200"), t + 0.1);
    m.Refresh(t + 0.2, true);
    EXPECT_EQ(m.model().processes[1].running, 2) << t;
    EXPECT_EQ(m.model().processes[1].restarts, 0) << t;
    if (t >= 2.5) {
      EXPECT_EQ(m.model().processes[0].running, 1) << t;
      EXPECT_EQ(m.model().processes[0].expected, 1) << t;
      EXPECT_EQ(m.model().processes[0].restarts, 1) << t;
    }
  }
  m.Refresh(8.5, true);
  const ConsoleProcess& store = m.model().processes[0];
  EXPECT_EQ(store.running, 1);
  EXPECT_EQ(store.restarts, 1);
  EXPECT_EQ(m.model().processes[1].restarts, 0);
  EXPECT_EQ(m.model().processes[2].problem, "unit U3: device gone");
  EXPECT_NE(ConsoleProcessesLine(m.model()).find("store up (restarted 1x)"), std::string::npos);
  // The end of the station: every instance silent together is no restart.
  m.Refresh(20.0, true);
  EXPECT_EQ(m.model().processes[1].running, 0);
  EXPECT_EQ(m.model().processes[1].restarts, 0);
  EXPECT_EQ(m.model().processes[0].restarts, 1);
  EXPECT_EQ(m.model().processes[2].problem, "");  // faded
}

TEST(StationMonitorTest, ASilentSerialUnitShowsNoDataThenReconnecting) {
  imuqual::run_t r = SerialRun();
  StationMonitor m = MonitorOf(r);
  m.Refresh(17.0, false);
  EXPECT_EQ(DescribeUnit(m.model(), m.model().units[0]).state, "no data 0:07");
  imuqual::status_t s = StatusMsg("acquire", "h:1");
  s.counter_names = {std::string(channels::kReconnectingCounterPrefix) + "R-U1"};
  s.counter_values = {1};
  s.num_counters = 1;
  m.OnStatus(s, 17.5);
  m.Refresh(18.0, false);
  EXPECT_EQ(DescribeUnit(m.model(), m.model().units[0]).state, "reconnecting 0:08");
  // Samples again: running.
  r.samples_published += 100;
  m.OnRun(r);
  m.Refresh(18.5, false);
  EXPECT_EQ(DescribeUnit(m.model(), m.model().units[0]).state, "running");
  // A simulated unit is never silent: it waits for the archive.
  m.OnRun(RunMsg("R-U2", "U2", "A2"));
  m.Refresh(30.0, false);
  m.Refresh(60.0, false);
  EXPECT_EQ(DescribeUnit(m.model(), m.model().units[1]).state, "running");
}

TEST(StationMonitorTest, CurvesInDatasheetUnitsThinnedFinalKept) {
  StationMonitor m = CurveMonitor();
  imuqual::allan_curve_t c = Curve("gy", 1000);
  m.OnCurve(c);
  std::vector<LiveCurve> curves = m.Curves(m.model().units[0]);
  ASSERT_EQ(curves.size(), 1u);
  const LiveCurve& live = curves[0];
  EXPECT_EQ(live.axis, "gy");
  EXPECT_EQ(live.unit, "deg/h");
  EXPECT_LE(live.tau_s.size(), kMaxLiveCurvePoints + 1);
  EXPECT_GE(live.tau_s.size(), kMaxLiveCurvePoints / 2);
  EXPECT_DOUBLE_EQ(live.tau_s.front(), 0.01);
  EXPECT_DOUBLE_EQ(live.tau_s.back(), 10.0);
  EXPECT_DOUBLE_EQ(live.dev.front(), 1e-3 / std::sqrt(0.01) * 3600);
  for (size_t i = 1; i < live.tau_s.size(); ++i) EXPECT_GT(live.tau_s[i], live.tau_s[i - 1]);
  // The final curve stays; a late interim one does not replace it.
  c.is_final = true;
  c.dev[0] = 2e-3 / std::sqrt(0.01);
  m.OnCurve(c);
  c.is_final = false;
  c.dev[0] = 5e-3;
  m.OnCurve(c);
  curves = m.Curves(m.model().units[0]);
  EXPECT_TRUE(curves[0].is_final);
  EXPECT_DOUBLE_EQ(curves[0].dev.front(), 2e-3 / std::sqrt(0.01) * 3600);
  // An accelerometer's curve in ug.
  c.axis = "gx";
  c.axis_kind = imuqual::rate_batch_t::KIND_ACCEL;
  c.dev[0] = 9.80665e-6;
  m.OnCurve(c);
  curves = m.Curves(m.model().units[0]);
  ASSERT_EQ(curves.size(), 2u);
  EXPECT_EQ(curves[0].axis, "gx");  // the run's axis order
  EXPECT_EQ(curves[0].unit, "ug");
  EXPECT_NEAR(curves[0].dev.front(), 1.0, 1e-12);
}

}  // namespace
}  // namespace imuqual::station

namespace imuqual::station {
namespace {

// The plan each run carries gives every axis its bias-instability limits,
// for the live page's plots: an axis-specific limit over the kind's.
TEST(StationMonitorTest, EachAxisCarriesThePlansLimitsOnItsCurveMinimum) {
  pb::TestPlan plan;
  plan.set_nominal_rate_hz(100);
  pb::Limit* all = plan.add_limits();
  all->set_measurement("bias_instability");
  all->set_axis_kind(pb::GYRO);
  all->set_high(20);
  all->set_marginal_high(16);
  all->set_unit("deg/h");
  pb::Limit* gy = plan.add_limits();
  gy->set_measurement("bias_instability");
  gy->add_axes("gy");
  gy->set_high(12);
  gy->set_unit("deg/h");
  imuqual::run_t r = RunMsg("R-U1", "U1", "A1");
  const std::string bytes = plan.SerializeAsString();
  r.plan.assign(bytes.begin(), bytes.end());
  r.plan_size = static_cast<int32_t>(r.plan.size());
  MonitorOptions o;
  o.discover_units = true;
  StationMonitor m(o);
  m.OnRun(r);
  ASSERT_EQ(m.model().units.size(), 1u);
  const auto& axes = m.model().units[0].axes;
  ASSERT_EQ(axes.size(), 2u);
  EXPECT_EQ(axes[0].limit_high, 20);
  EXPECT_EQ(axes[0].marginal_high, 16);
  EXPECT_EQ(axes[1].limit_high, 12);
  EXPECT_TRUE(std::isnan(axes[1].marginal_high));
}

}  // namespace
}  // namespace imuqual::station
