// Nothing lost: the station under faults, over real LCM multicast (private
// network namespace when ctest can make one). Each test kills or starves a
// process of a running soak and checks the archive afterwards: every batch
// there, or recorded as a gap with the verdict saying so; results equal to
// an undisturbed run's; nothing left hanging.
#include <dirent.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "common/clock.h"
#include "common/text_util.h"
#include "store/archive.h"
#include "store/reanalysis.h"
#include "tests/archive_checks.h"
#include "tests/station_harness.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::CheckArchive;
using testing::ExpectEveryRunWhole;
using testing::ExpectSoakArchivedWhole;
using testing::RunCommand;
using testing::StationHarness;

constexpr double kRunTimeoutS = 120;  // bound on any wait for a run to end

// Acquire arguments for `units` simulated vg700 units of `lot`.
std::vector<std::string> AcquireArgs(const std::string& lot, int units, double duration_s,
                                     double pace, const std::string& prefix) {
  // One datagram per batch, as across a station LAN: many small batches to
  // lose and repair.
  std::vector<std::string> args = {"--lot", lot, "--sim", std::to_string(units), "--duration",
                                   std::to_string(duration_s), "--await", "store,analyze",
                                   "--run-prefix", prefix, "--seed", "7", "--plan",
                                   "builtin:vg700ca", "--batch-bytes", "1399"};
  if (pace > 0) args.insert(args.end(), {"--pace", std::to_string(pace)});
  return args;
}

// Waits (bounded) until the archive holds at least `chunks` raw chunks.
bool WaitArchived(StationHarness& h, int64_t chunks, double timeout_s) {
  return h.WaitCounter("store", "chunks_inserted", chunks, timeout_s) >= chunks;
}

// The archived curves of a run equal the analysis of its archived samples.
void ExpectResultEqualsReanalysis(const std::string& db, const std::string& run_id) {
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  auto outcome = store::ReanalyzeRun(**a, run_id);
  ASSERT_TRUE(outcome.ok()) << outcome.status().ToString();
  auto curves = (*a)->LoadCurves(**(*a)->FindRunKey(run_id));
  ASSERT_TRUE(curves.ok());
  ASSERT_EQ(curves->size(), outcome->curves.size()) << run_id;
  for (size_t i = 0; i < curves->size(); ++i) {
    const auto& live = (*curves)[i].curve.points;
    const auto& again = outcome->curves[i].second.points;
    ASSERT_EQ(live.size(), again.size());
    for (size_t p = 0; p < live.size(); ++p) EXPECT_EQ(live[p].dev, again[p].dev) << run_id;
  }
}

// An undisturbed soak of `units` seeded units of `lot` (runs CLEAN-<serial>),
// the reference a disturbed soak of the same units is compared with.
void SoakUndisturbed(StationHarness& h, const std::string& lot, int units, double duration_s) {
  Subprocess clean = h.Start("imuqual-acquire", AcquireArgs(lot, units, duration_s, 0, "CLEAN"));
  ASSERT_TRUE(h.WaitRunsDone(static_cast<size_t>(units), kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(clean.Wait(30), 0);
}

// Two runs of the same seeded unit have the same curves, bit for bit, on
// each of the `axes` axes.
void ExpectSameCurves(store::Archive& a, const std::string& run_a, const std::string& run_b,
                      size_t axes) {
  auto x_curves = a.LoadCurves(**a.FindRunKey(run_a));
  auto y_curves = a.LoadCurves(**a.FindRunKey(run_b));
  ASSERT_TRUE(x_curves.ok() && y_curves.ok());
  ASSERT_EQ(x_curves->size(), axes) << run_a;
  ASSERT_EQ(y_curves->size(), axes) << run_b;
  for (size_t i = 0; i < axes; ++i) {
    const auto& x = (*x_curves)[i].curve.points;
    const auto& y = (*y_curves)[i].curve.points;
    ASSERT_EQ(x.size(), y.size()) << run_b;
    for (size_t p = 0; p < x.size(); ++p) {
      EXPECT_EQ(x[p].dev, y[p].dev) << run_b << " m=" << x[p].m;
      EXPECT_EQ(x[p].n, y[p].n) << run_b << " m=" << x[p].m;
    }
  }
}

// Two runs of the same seeded unit have the same judgement (verdict, reasons,
// samples) and the same curves, bit for bit, on each of the `axes` axes.
void ExpectSameJudgement(store::Archive& a, const std::string& run_a, const std::string& run_b,
                         size_t axes) {
  auto x = a.LoadResult(**a.FindRunKey(run_a));
  auto y = a.LoadResult(**a.FindRunKey(run_b));
  ASSERT_TRUE(x.ok() && x->has_value()) << run_a;
  ASSERT_TRUE(y.ok() && y->has_value()) << run_b;
  EXPECT_EQ((*y)->verdict, (*x)->verdict) << run_b;
  EXPECT_EQ((*y)->reasons, (*x)->reasons) << run_b;
  EXPECT_EQ((*y)->samples, (*x)->samples) << run_b;
  ExpectSameCurves(a, run_a, run_b, axes);
}

TEST(FaultTest, InjectedDropsAreRepairedToZeroGaps) {
  // The acceptance line, through the CLI.
  testing::TempDir dir("fault_drop");
  const std::string db = dir.path("drop.db");
  const auto run = RunCommand(Bin("imuqual") + " run --sim 4 --duration 600 --short-soak --rate 200 --lot DROP --db " +
                              db + " --inject-drop 0.05 --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  auto log = ReadFileToString(db + ".log");
  ASSERT_TRUE(log.ok());
  // The drops really happened: acquire reports how many it withheld.
  const size_t at = log->find(" dropped on purpose");
  ASSERT_NE(at, std::string::npos) << *log;
  const size_t start = log->rfind(' ', at - 1) + 1;
  EXPECT_GT(std::stoll(log->substr(start, at - start)), 10) << *log;

  const auto csv = RunCommand(Bin("imuqual") + " lot DROP --db " + db + " --format csv");
  ASSERT_EQ(csv.exit_code, 0);
  std::istringstream in(csv.output);
  std::string line;
  std::getline(in, line);
  const auto cols = Split(line, ',');
  const size_t gap_col = std::find(cols.begin(), cols.end(), "gap_samples") - cols.begin();
  int rows = 0;
  while (std::getline(in, line)) {
    EXPECT_EQ(Split(line, ',')[gap_col], "0") << line;
    ++rows;
  }
  EXPECT_EQ(rows, 4 * 3);
  for (const auto& [id, c] : CheckArchive(db)) {
    EXPECT_EQ(c.chunks, c.last_seq + 1) << id;
    EXPECT_EQ(c.gap_ranges, 0) << id;
  }
}

// Results are repaired like raw batches: with half of the final curves and
// results lost on their first publication, analyze publishes them again
// until the store confirms each run archived, which it does only once it
// holds a final curve of every axis and the judgement.
TEST(FaultTest, LostResultsArePublishedAgainUntilArchived) {
  StationHarness h("fault_results");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze({"--inject-result-drop", "0.5"});
  Subprocess acquire = h.Start("imuqual-acquire", AcquireArgs("FRES", 4, 600, 0, "RES"));
  ASSERT_TRUE(h.WaitRunsDone(4, kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(acquire.Wait(30), 0);
  // Not vacuous: results were lost and published again.
  EXPECT_GT(h.WaitCounter("analyze", "results_dropped_on_purpose", 1, 10), 0);
  EXPECT_GT(h.WaitCounter("analyze", "results_republished", 1, 10), 0);
  auto a = store::Archive::Open(h.db(), store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  const auto runs = CheckArchive(h.db());
  ASSERT_EQ(runs.size(), 4u);
  ExpectEveryRunWhole(runs);
  for (const auto& [id, c] : runs) {
    auto curves = (*a)->LoadCurves(**(*a)->FindRunKey(id));
    ASSERT_TRUE(curves.ok());
    EXPECT_EQ(curves->size(), 3u) << id << " lacks a curve";
    ExpectResultEqualsReanalysis(h.db(), id);
    // And the check that an auditor runs agrees.
    const auto check = RunCommand(Bin("imuqual") + " reanalyze " + id + " --check --db " + h.db() +
                                  " > /dev/null");
    EXPECT_EQ(check.exit_code, 0) << id << ": " << check.output;
  }
  // A run whose archive lacks a curve or its judgement fails that check,
  // saying what is missing.
  const std::string id = runs.begin()->first;
  a->reset();
  {
    auto w = store::Archive::Open(h.db(), store::Archive::Mode::kWrite);
    ASSERT_TRUE(w.ok()) << w.status().ToString();
    const std::string key = std::to_string(**(*w)->FindRunKey(id));
    ASSERT_TRUE((*w)->db().Exec("DELETE FROM curve_points WHERE run_key = " + key + " AND axis = 'y'").ok());
    ASSERT_TRUE((*w)->db().Exec("DELETE FROM curves WHERE run_key = " + key + " AND axis = 'y'").ok());
    ASSERT_TRUE((*w)->db().Exec("UPDATE runs SET verdict = NULL, record = NULL, result_utime = NULL "
                                "WHERE run_key = " + key).ok());
  }
  const auto check = RunCommand(Bin("imuqual") + " reanalyze " + id + " --check --db " + h.db() +
                                " 2>&1 > /dev/null");
  EXPECT_EQ(check.exit_code, 1) << check.output;
  EXPECT_NE(check.output.find("axis y: no archived curve"), std::string::npos) << check.output;
  EXPECT_NE(check.output.find("no judgement archived"), std::string::npos) << check.output;
}

// Datagram loss in the kernel, for every message alike (batches, heartbeats,
// acks, resend requests, curves, results): an nftables rule in this test's
// private network namespace drops 10 %, then 30 %, of the UDP datagrams sent.
// A whole station (`imuqual run`, 4 units) still ends with every sample,
// every curve and every verdict archived, no gap, and exit 0.
TEST(FaultTest, DatagramLossInTheKernelLosesNothing) {
  const char* netns = std::getenv("IMUQUAL_NETNS");
  ASSERT_TRUE(netns != nullptr && std::string(netns) == "1")
      << "this test rewrites the network's filter rules: it runs only in a private network "
         "namespace (tests/netns_run)";
  for (int percent : {10, 30}) {
    SCOPED_TRACE(std::to_string(percent) + " % loss");
    testing::TempDir dir("kernel_loss");
    const std::string db = dir.path("loss.db");
    const std::string rule = "nft add table inet imuqual_loss && nft add chain inet imuqual_loss out "
                             "'{ type filter hook output priority 0; }' && nft add rule inet "
                             "imuqual_loss out meta l4proto udp numgen random mod 100 '<' " +
                             std::to_string(percent) + " drop";
    const auto added = RunCommand(rule + " 2>&1");
    ASSERT_EQ(added.exit_code, 0) << "nftables: " << added.output;
    const auto run = RunCommand(Bin("imuqual") + " run --sim 4 --profile vg700 --duration 900 --short-soak "
                                "--lot LOSS --quiet --db " + db + " 2>&1");
    (void)RunCommand("nft delete table inet imuqual_loss");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    ExpectSoakArchivedWhole(db, 4, 3);
  }
}

// A disk that fills during a soak and is freed a minute later, long after
// every give-up timer (the harness's store gives holes up after 5 s): the store holds what
// it cannot write, acknowledges nothing it has not archived, and once there
// is room writes it all; acquire keeps what was not acknowledged. Nothing is
// lost and no gap is recorded. (A disk never freed: bad_input_test.)
TEST(FaultTest, ADiskFullForAMinuteAndThenFreedLosesNothing) {
  const char* netns = std::getenv("IMUQUAL_NETNS");
  ASSERT_TRUE(netns != nullptr && std::string(netns) == "1")
      << "this test mounts a small filesystem: it runs only in the private mount namespace of "
         "tests/netns_run";
  StationHarness h("fault_disk");
  const std::string disk = h.path("disk");
  std::filesystem::create_directories(disk);
  ASSERT_EQ(::mount("tmpfs", disk.c_str(), "tmpfs", 0, "size=48m"), 0) << std::strerror(errno);
  struct Unmount {
    std::string dir;
    ~Unmount() { ::umount2(dir.c_str(), MNT_DETACH); }
  } unmount{disk};
  const std::string db = disk + "/archive.db";
  Subprocess store = h.StartStore({"--db", db});
  Subprocess analyze = h.StartAnalyze();
  Subprocess acquire = h.Start("imuqual-acquire", AcquireArgs("FDISK", 2, 1500, 100, "DISK"));
  // GIVEN a soak under way with data committed
  ASSERT_TRUE(WaitArchived(h, 50, 30)) << h.Logs();
  // WHEN the disk fills up
  const std::string filler = disk + "/filler";
  {
    std::ofstream out(filler, std::ios::binary);
    const std::string block(1 << 16, 'x');
    while (out.write(block.data(), static_cast<std::streamsize>(block.size()))) {
    }
  }
  const int64_t failures_before = h.Counter("store", "commit_failures");
  // ... for a minute, longer than the store's give-up time
  const double until = MonotonicSeconds() + 60;
  while (MonotonicSeconds() < until) h.Pump(100);
  EXPECT_GT(h.Counter("store", "commit_failures"), failures_before) << "the disk never filled";
  // ... and is then freed
  std::filesystem::remove(filler);
  // THEN every run ends complete: every batch archived, no gap, judged.
  ASSERT_TRUE(h.WaitRunsDone(2, kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(acquire.Wait(60).value_or(-1), 0);
  const auto runs = CheckArchive(db);
  ASSERT_EQ(runs.size(), 2u);
  ExpectEveryRunWhole(runs);
  for (const auto& [id, c] : runs) ExpectResultEqualsReanalysis(db, id);
  EXPECT_EQ(h.Counter("store", "unwritten_dropped"), 0);
}

TEST(FaultTest, StoreKilledMidRunRestartsWithoutLosingABatch) {
  StationHarness h("fault_store");
  // The store signs what it archives (imuqual-store --sign-key).
  const std::string key = h.path("store.key");
  ASSERT_EQ(RunCommand(Bin("imuqual") + " keygen --role store --out " + key + " 2>&1").exit_code,
            0);
  Subprocess store = h.StartStore({"--sign-key", key});
  Subprocess analyze = h.StartAnalyze();
  Subprocess acquire = h.Start("imuqual-acquire", AcquireArgs("FSTORE", 2, 1200, 200, "P1"));
  // GIVEN a soak under way with data committed
  ASSERT_TRUE(WaitArchived(h, 100, 30)) << h.Logs();
  // WHEN the archiver is killed outright
  ::kill(store.pid(), SIGKILL);
  store.Stop(5);
  // THEN the file opens and holds what was committed
  int64_t committed = 0;
  for (const auto& [id, c] : CheckArchive(h.db())) committed += c.chunks;
  EXPECT_GT(committed, 0);
  // AND a restarted store catches up: every batch, no gap.
  Subprocess store2 = h.StartStore({"--sign-key", key});
  ASSERT_TRUE(h.WaitRunsDone(2, kRunTimeoutS)) << h.Logs();
  const auto runs = CheckArchive(h.db());
  ExpectEveryRunWhole(runs);
  int64_t total = 0;
  for (const auto& [id, c] : runs) total += c.chunks;
  EXPECT_GE(total, committed);
  EXPECT_EQ(acquire.Wait(30), 0);
  // AND the restarted store signed both runs, each in one chain, whole.
  const auto verify =
      RunCommand(Bin("imuqual") + " verify --db " + h.db() + " --pubkey " + key + ".pub 2>&1");
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  EXPECT_NE(verify.output.find("chain: 2 entries"), std::string::npos) << verify.output;
  EXPECT_NE(verify.output.find("signed and verified: 2 runs"), std::string::npos) << verify.output;
}

TEST(FaultTest, AnalyzeKilledMidRunGivesTheUninterruptedResult) {
  StationHarness h("fault_analyze");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  // An undisturbed run of the same units (same seed) ...
  SoakUndisturbed(h, "FAN", 2, 900);
  if (HasFatalFailure()) return;
  // ... and one whose analysis is killed half way and restarted.
  Subprocess acquire = h.Start("imuqual-acquire", AcquireArgs("FAN", 2, 900, 150, "KILLED"));
  ASSERT_TRUE(WaitArchived(h, h.Counter("store", "chunks_inserted") + 300, 30)) << h.Logs();
  ::kill(analyze.pid(), SIGKILL);
  analyze.Stop(5);
  Subprocess analyze2 = h.StartAnalyze();
  ASSERT_TRUE(h.WaitRunsDone(4, kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(acquire.Wait(30), 0);

  auto a = store::Archive::Open(h.db(), store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  for (const std::string unit : {"FAN-U01", "FAN-U02"}) {
    ExpectSameCurves(**a, "CLEAN-" + unit, "KILLED-" + unit, 3);
  }
  for (const auto& [id, c] : CheckArchive(h.db())) EXPECT_EQ(c.gap_ranges, 0) << id;
}

// A process frozen (SIGSTOP: Ctrl-Z, a paused VM, a swap storm) for a
// minute, far longer than every one of its timers (the harness's store:
// give-up 5 s, stale-after 2 s; analyze: 5 s and 4 s) and than its socket
// buffer holds, then woken: it judges silence by its own listening time and
// has what it missed resent, so nothing it was doing is cut short.
constexpr int kFreezeS = 60;

void Freeze(const Subprocess& p, int seconds) {
  ::kill(p.pid(), SIGSTOP);
  const double until = MonotonicSeconds() + seconds;
  while (MonotonicSeconds() < until) ::usleep(100000);
  ::kill(p.pid(), SIGCONT);
}

TEST(FaultTest, StoreFrozenForAMinuteLosesNothing) {
  StationHarness h("fault_store_frozen");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  Subprocess acquire = h.Start("imuqual-acquire", AcquireArgs("FFROZ", 2, 1500, 100, "FROZEN"));
  // GIVEN a soak under way with data committed
  ASSERT_TRUE(WaitArchived(h, 100, 30)) << h.Logs();
  // WHEN the archiver is frozen while acquire keeps publishing
  Freeze(store, kFreezeS);
  // THEN it catches up: every run complete, every batch, no gap, judged.
  ASSERT_TRUE(h.WaitRunsDone(2, kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(acquire.Wait(30), 0);
  const auto runs = CheckArchive(h.db());
  ASSERT_EQ(runs.size(), 2u);
  ExpectEveryRunWhole(runs);
  for (const auto& [id, c] : runs) ExpectResultEqualsReanalysis(h.db(), id);
}

TEST(FaultTest, AnalyzeFrozenForAMinuteGivesTheUninterruptedResult) {
  StationHarness h("fault_analyze_frozen");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  // An undisturbed run of the same units (same seed) ...
  SoakUndisturbed(h, "FAF", 2, 1500);
  if (HasFatalFailure()) return;
  // ... and one whose analysis is frozen half way.
  Subprocess acquire = h.Start("imuqual-acquire", AcquireArgs("FAF", 2, 1500, 100, "FROZEN"));
  ASSERT_TRUE(WaitArchived(h, h.Counter("store", "chunks_inserted") + 200, 30)) << h.Logs();
  Freeze(analyze, kFreezeS);
  ASSERT_TRUE(h.WaitRunsDone(4, kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(acquire.Wait(30), 0);
  auto a = store::Archive::Open(h.db(), store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  for (const std::string unit : {"FAF-U01", "FAF-U02"}) {
    ExpectSameJudgement(**a, "CLEAN-" + unit, "FROZEN-" + unit, 3);
  }
  ExpectEveryRunWhole(CheckArchive(h.db()));
}

// acquire frozen (a paused host, a cut cable) for longer than the store's
// silence timer: the store ends its runs as incomplete and they are judged on
// what arrived. When acquire wakes and goes on, the runs open again: the
// early judgement is kept as superseded, with why, and each run is archived
// and judged on all its data, as if nothing had happened.
TEST(FaultTest, AcquireFrozenPastSilenceIsJudgedAgainOnAllItsData) {
  StationHarness h("fault_acquire_frozen");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  // An undisturbed run of the same units (same seed) ...
  SoakUndisturbed(h, "FAQF", 2, 1500);
  if (HasFatalFailure()) return;
  // ... and one whose acquire is frozen a third of the way in.
  Subprocess acquire = h.Start("imuqual-acquire", AcquireArgs("FAQF", 2, 1500, 100, "FROZEN"));
  ASSERT_TRUE(WaitArchived(h, h.Counter("store", "chunks_inserted") + 100, 30)) << h.Logs();
  ::kill(acquire.pid(), SIGSTOP);
  // GIVEN both runs ended as incomplete and judged on their first part
  ASSERT_TRUE(h.WaitRunsDone(4, kRunTimeoutS)) << h.Logs();
  const auto early = CheckArchive(h.db());
  for (const std::string unit : {"FAQF-U01", "FAQF-U02"}) {
    ASSERT_EQ(early.at("FROZEN-" + unit).state, "incomplete") << h.Logs();
    EXPECT_NE(early.at("FROZEN-" + unit).verdict, "") << unit;
  }
  // WHEN acquire wakes and the soak goes on to its end
  ::kill(acquire.pid(), SIGCONT);
  EXPECT_EQ(acquire.Wait(kRunTimeoutS), 0) << h.Logs();
  // THEN both runs are judged again (bounded wait for the new round's end)
  const double deadline = MonotonicSeconds() + kRunTimeoutS;
  auto judged_again = [&] {
    auto a = store::Archive::Open(h.db(), store::Archive::Mode::kRead);
    return a.ok() && *(*a)->db().QueryInt(
                         "SELECT COUNT(*) FROM runs WHERE run_id LIKE 'FROZEN-%' AND revision = 1 "
                         "AND finalized_utime IS NOT NULL") == 2;
  };
  while (!judged_again() && MonotonicSeconds() < deadline) h.Pump(200);
  ASSERT_TRUE(judged_again()) << h.Logs();
  EXPECT_GE(h.WaitCounter("store", "judgements_superseded", 2, 5), 2);
  EXPECT_GE(h.WaitCounter("analyze", "runs_reopened", 2, 5), 2);
  // AND the archive is whole, the early judgement kept with its cause
  const auto runs = CheckArchive(h.db());
  ExpectEveryRunWhole(runs);
  auto a = store::Archive::Open(h.db(), store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  for (const std::string unit : {"FAQF-U01", "FAQF-U02"}) {
    const std::string id = "FROZEN-" + unit;
    const std::string key = std::to_string(**(*a)->FindRunKey(id));
    auto s = (*a)->db().Prepare("SELECT revision, verdict, cause FROM superseded_judgements "
                                "WHERE run_key = " + key);
    ASSERT_TRUE(*s->Step()) << id << " kept no superseded judgement";
    EXPECT_EQ(s->Int(0), 0);
    EXPECT_EQ(s->Text(1), early.at(id).verdict);
    EXPECT_NE(s->Text(2).find("after it had ended as incomplete (acquire silent"),
              std::string::npos)
        << s->Text(2);
    // AND the new judgement is the undisturbed run's, on all the data
    ExpectSameJudgement(**a, "CLEAN-" + unit, id, 3);
    const auto check =
        RunCommand(Bin("imuqual") + " reanalyze " + id + " --check --db " + h.db() + " 2>&1");
    EXPECT_EQ(check.exit_code, 0) << check.output;
  }
  // AND `imuqual verify` finds every checksum (superseded rows included) intact.
  const auto verify = RunCommand(Bin("imuqual") + " verify --db " + h.db() + " 2>&1");
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
}

TEST(FaultTest, AnalyzeRestartedAfterAcquireLeftCatchesUpFromTheArchive) {
  StationHarness h("fault_archive");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  // acquire waits for the store only (as with a device-paced source, the
  // soak goes on while the analysis is down) and leaves once it is archived.
  std::vector<std::string> args = AcquireArgs("FARCH", 1, 900, 150, "P3");
  *std::find(args.begin(), args.end(), "store,analyze") = "store";
  args.insert(args.end(), {"--linger", "1"});
  Subprocess acquire = h.Start("imuqual-acquire", args);
  ASSERT_TRUE(WaitArchived(h, 200, 30)) << h.Logs();
  ::kill(analyze.pid(), SIGKILL);
  analyze.Stop(5);
  // acquire finishes (store acknowledged everything) and leaves.
  EXPECT_EQ(acquire.Wait(60), 0);
  // A new analyze learns the run from the store's re-announcement and gets
  // every batch from the archive.
  Subprocess analyze2 = h.StartAnalyze();
  ASSERT_TRUE(h.WaitRunsDone(1, kRunTimeoutS)) << h.Logs();
  // Status reports come once a second.
  EXPECT_GT(h.WaitCounter("store", "batches_served", 1, 5), 0) << h.Logs();
  for (const auto& [id, c] : CheckArchive(h.db())) {
    EXPECT_EQ(c.state, "complete") << id;
    EXPECT_EQ(c.gap_ranges, 0) << id;
    EXPECT_NE(c.verdict, "") << id;
    ExpectResultEqualsReanalysis(h.db(), id);
  }
}

TEST(FaultTest, AcquireKilledEndsTheRunIncompleteAndNothingHangs) {
  StationHarness h("fault_acquire");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  Subprocess acquire = h.Start("imuqual-acquire", AcquireArgs("FACQ", 2, 3600, 100, "P4"));
  ASSERT_TRUE(WaitArchived(h, 100, 30)) << h.Logs();
  ::kill(acquire.pid(), SIGKILL);
  acquire.Stop(5);
  // The store notices the silence, ends the runs as incomplete, the analysis
  // judges what was measured; the verdict is ERROR (the source failed, which
  // says nothing about the unit).
  ASSERT_TRUE(h.WaitRunsDone(2, kRunTimeoutS)) << h.Logs();
  for (const auto& [id, c] : CheckArchive(h.db())) {
    EXPECT_EQ(c.state, "incomplete") << id;
    EXPECT_EQ(c.verdict, "ERROR") << id;
    EXPECT_NE(c.reasons.find("run incomplete"), std::string::npos) << c.reasons;
    EXPECT_GT(c.chunks, 0) << id;
  }
  // Both keep running and stop cleanly when asked.
  EXPECT_FALSE(store.Poll().has_value());
  EXPECT_FALSE(analyze.Poll().has_value());
  EXPECT_EQ(analyze.Stop(15), 0);
  EXPECT_EQ(store.Stop(15), 0);
}

// Processes whose command line mentions `needle`, by pid, with the program
// each runs (argv[0]'s file name). A child forked but not yet exec'd carries
// its parent's command line, and for a moment inside exec none at all: count
// programs, not processes, when waiting for a station to be up.
std::map<pid_t, std::string> ProcessesMentioning(const std::string& needle) {
  std::map<pid_t, std::string> found;
  DIR* proc = ::opendir("/proc");
  if (proc == nullptr) return found;
  while (dirent* e = ::readdir(proc)) {
    const pid_t pid = static_cast<pid_t>(std::atoi(e->d_name));
    if (pid <= 0 || pid == ::getpid()) continue;
    std::ifstream in("/proc/" + std::string(e->d_name) + "/cmdline");
    std::string cmdline((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (cmdline.find(needle) == std::string::npos) continue;
    const std::string argv0 = cmdline.substr(0, cmdline.find('\0'));
    found[pid] = argv0.substr(argv0.find_last_of('/') + 1);
  }
  ::closedir(proc);
  return found;
}

TEST(FaultTest, KillingImuqualRunLeavesNoOrphans) {
  testing::TempDir dir("fault_orphans");
  const std::string db = dir.path("orphans.db");
  // A bus URL of its own: every station process names it on its command line.
  BusAddress bus;
  bus.port = 20000 + ::getpid() % 40000;
  const std::string url = bus.ToUrl();
  auto run = Subprocess::Start({Bin("imuqual"), "run", "--sim", "2", "--duration", "3600", "--short-soak", "--pace",
                                "20", "--lot", "ORPHAN", "--db", db, "--lcm-url", url, "--quiet"},
                               dir.path("run.log"));
  ASSERT_TRUE(run.ok());
  // GIVEN imuqual run with its store, analyze and acquire running
  const std::set<std::string> station = {"imuqual", "imuqual-store", "imuqual-analyze",
                                         "imuqual-acquire"};
  // Waited for and asserted on one snapshot: its programs and its count.
  const double start_deadline = MonotonicSeconds() + 30;
  std::map<pid_t, std::string> up;
  std::set<std::string> programs;
  for (;;) {
    up = ProcessesMentioning(url);
    programs.clear();
    for (const auto& [pid, program] : up) programs.insert(program);
    if (programs == station || MonotonicSeconds() >= start_deadline) break;
    ::usleep(20000);
  }
  ASSERT_EQ(programs, station);
  ASSERT_EQ(up.size(), 4u);
  // ... and both runs archived as started
  auto archived_runs = [&] {
    auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
    if (!a.ok()) return int64_t{0};
    auto n = (*a)->db().QueryInt("SELECT COUNT(*) FROM runs");
    return n.ok() ? *n : int64_t{0};
  };
  while (archived_runs() < 2 && MonotonicSeconds() < start_deadline + 30) ::usleep(50000);
  ASSERT_EQ(archived_runs(), 2);
  // WHEN imuqual run is killed outright
  ::kill(run->pid(), SIGKILL);
  run->Stop(5);
  // THEN every child goes too (bounded wait).
  const double deadline = MonotonicSeconds() + 20;
  while (!ProcessesMentioning(url).empty() && MonotonicSeconds() < deadline) ::usleep(50000);
  EXPECT_TRUE(ProcessesMentioning(url).empty());
  // The archive opens and is consistent.
  CheckArchive(db);
  // Which runs the crash left unjudged: a child that outlived its parent by a
  // moment may still have judged one (the analysis finishing an aborted run
  // before its own parent-death signal). The next run must find exactly the
  // others.
  std::set<std::string> left_open;
  {
    auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
    ASSERT_TRUE(a.ok());
    auto s = (*a)->db().Prepare(
        "SELECT run_id FROM runs WHERE lot = 'ORPHAN' AND finalized_utime IS NULL");
    while (*s->Step()) left_open.insert(s->Text(0));
  }
  // AND the station's next run on that archive judges the runs the crash
  // left open, finishes them and says so; none is left running. Killed
  // outright, imuqual run's children get their parent-death signal: an
  // acquire that still announced its runs' end before the store went has
  // them aborted (ABORTED: a stop), else the store finds acquire silent and
  // they are incomplete (ERROR: a station fault, not the units').
  const auto next = RunCommand(Bin("imuqual") + " run --sim 1 --duration 600 --short-soak --lot ORPHAN2 --db " +
                               db + " --lcm-url '" + url + "' 2>&1");
  EXPECT_EQ(next.exit_code, 0) << next.output;
  if (!left_open.empty()) {
    EXPECT_NE(next.output.find(std::to_string(left_open.size()) +
                               " run(s) left open by an earlier station process:"),
              std::string::npos)
        << next.output;
  }
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  auto s = (*a)->db().Prepare(
      "SELECT run_id, state, COALESCE(verdict, ''), finalized_utime IS NOT NULL FROM runs "
      "WHERE lot = 'ORPHAN' ORDER BY run_id");
  int left = 0;
  while (*s->Step()) {
    ++left;
    const std::string ending = s->Text(1) + ", " + s->Text(2);
    EXPECT_TRUE(ending == "incomplete, ERROR" || ending == "aborted, ABORTED")
        << s->Text(0) << ": " << ending;
    EXPECT_EQ(s->Int(3), 1) << s->Text(0);
    // The next run names each run it found open, and only those.
    EXPECT_EQ(next.output.find(s->Text(0) + ": " + ending + ": run ") != std::string::npos,
              left_open.count(s->Text(0)) == 1)
        << s->Text(0) << "\n"
        << next.output;
  }
  EXPECT_EQ(left, 2);
  auto running = (*a)->db().QueryInt("SELECT COUNT(*) FROM runs WHERE state = 'running'");
  ASSERT_TRUE(running.ok());
  EXPECT_EQ(*running, 0);
}

}  // namespace
}  // namespace imuqual
