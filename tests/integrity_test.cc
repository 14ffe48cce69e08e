// End-to-end integrity: batches damaged in flight are caught, dropped and
// resent (the archive and the results equal a clean run's); damage at rest
// is found by `imuqual verify` and `imuqual reanalyze --check`; a damaged
// archive is never written into.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>

#include "common/text_util.h"
#include "store/archive.h"
#include "store/checksums.h"
#include "store/sqlite.h"
#include "tests/station_harness.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::RunCommand;
using testing::StationHarness;

constexpr double kRunTimeoutS = 180;  // bound on any wait for the runs to end
constexpr int kUnits = 4;

// One simulated soak through a hand-assembled station; `extra` goes to acquire.
void Soak(StationHarness& h, const std::vector<std::string>& extra) {
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  // One datagram per batch, as across a station LAN: many batches to damage.
  std::vector<std::string> args = {
      "--lot",  "FLIP",    "--sim",         std::to_string(kUnits), "--duration",
      "600",    "--await", "store,analyze", "--run-prefix",         "F",
      "--seed", "7",       "--plan",        "builtin:vg700ca",      "--batch-bytes",
      "1399"};
  args.insert(args.end(), extra.begin(), extra.end());
  Subprocess acquire = h.Start("imuqual-acquire", args);
  ASSERT_TRUE(h.WaitRunsDone(kUnits, kRunTimeoutS)) << h.Logs();
  // acquire ends by itself once every consumer has confirmed its runs
  // (under load that can follow the store's last confirmation by seconds).
  EXPECT_EQ(acquire.Wait(60).value_or(-1), 0) << h.Logs();
  h.Pump(1500);  // everyone's latest counters (status about once a second)
  EXPECT_EQ(analyze.Stop(15), 0);
  EXPECT_EQ(store.Stop(15), 0);
}

using Key = std::tuple<std::string, std::string, std::string>;  // run, axis, name or m

// Every judged value and curve point of an archive, keyed by run id.
std::map<Key, double> Results(const std::string& db) {
  std::map<Key, double> out;
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  EXPECT_TRUE(a.ok()) << a.status().ToString();
  if (!a.ok()) return out;
  auto m = (*a)->db().Prepare(
      "SELECT r.run_id, m.axis, m.name, m.value FROM measurements m JOIN runs r USING (run_key)");
  while (*m->Step()) out[{m->Text(0), m->Text(1), m->Text(2)}] = m->Real(3);
  auto p = (*a)->db().Prepare(
      "SELECT r.run_id, p.axis, p.estimator || ':' || p.m, p.dev FROM curve_points p "
      "JOIN runs r USING (run_key)");
  while (*p->Step()) out[{p->Text(0), p->Text(1), p->Text(2)}] = p->Real(3);
  auto v = (*a)->db().Prepare("SELECT run_id, COALESCE(verdict, '-') FROM runs");
  while (*v->Step()) out[{v->Text(0), "", "verdict:" + v->Text(1)}] = 1;
  return out;
}

int64_t Query(const std::string& db, const std::string& sql) {
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  EXPECT_TRUE(a.ok());
  return a.ok() ? *(*a)->db().QueryInt(sql) : -1;
}

TEST(IntegrityTest, BitsFlippedInFlightAreCaughtAndTheResultsEqualACleanRun) {
  // GIVEN the same seeded units soaked twice, once with 1 % of the datagrams
  // acquire sends carrying one flipped bit (after the checksum)
  StationHarness clean("integrity_clean");
  Soak(clean, {});
  StationHarness flipped("integrity_flip");
  Soak(flipped, {"--inject-bitflip", "0.01"});

  // THEN the damage really happened and was caught by both consumers
  const int64_t injected = flipped.Counter("acquire", "injected_bitflips");
  const int64_t store_damaged = flipped.Counter("store", "batches_damaged");
  const int64_t store_undecodable = flipped.Counter("store", "decode_errors");
  const int64_t analyze_damaged = flipped.Counter("analyze", "batches_damaged");
  const int64_t analyze_undecodable = flipped.Counter("analyze", "decode_errors");
  std::printf(
      "bit flips injected %lld; store: %lld damaged + %lld undecodable; analyze: %lld + %lld\n",
      static_cast<long long>(injected), static_cast<long long>(store_damaged),
      static_cast<long long>(store_undecodable), static_cast<long long>(analyze_damaged),
      static_cast<long long>(analyze_undecodable));
  EXPECT_GT(injected, 5);
  EXPECT_GT(store_damaged, 0);
  EXPECT_GT(analyze_damaged, 0);
  // Every flipped datagram that arrived was refused, one way or the other.
  EXPECT_LE(store_damaged + store_undecodable, injected);
  EXPECT_LE(analyze_damaged + analyze_undecodable, injected);
  EXPECT_EQ(clean.Counter("store", "batches_damaged"), 0);

  // AND every sample is archived, no gap, and the archives' raw data and
  // results are those of the clean run, bit for bit.
  EXPECT_EQ(Query(flipped.db(), "SELECT COUNT(*) FROM gaps"), 0);
  EXPECT_EQ(Query(flipped.db(), "SELECT SUM(chunks - last_seq - 1) FROM run_archive"), 0);
  EXPECT_EQ(Query(flipped.db(), "SELECT SUM(num_samples) FROM raw_chunks"),
            Query(clean.db(), "SELECT SUM(num_samples) FROM raw_chunks"));
  const auto expected = Results(clean.db());
  const auto got = Results(flipped.db());
  ASSERT_FALSE(expected.empty());
  size_t differing = 0;
  for (const auto& [key, value] : expected) {
    auto it = got.find(key);
    if (it == got.end() || !(it->second == value || (value != value && it->second != it->second))) {
      ++differing;
    }
  }
  EXPECT_EQ(got.size(), expected.size());
  EXPECT_EQ(differing, 0u);
  // The damaged archive? None: verify finds it clean.
  EXPECT_EQ(RunCommand(Bin("imuqual") + " verify --db " + flipped.db()).exit_code, 0);
}

// A finished simulated run in a fresh archive, through the CLI.
std::string ArchiveOneRun(const testing::TempDir& dir) {
  const std::string db = dir.path("run.db");
  const auto run =
      RunCommand(Bin("imuqual") + " run --sim 1 --duration 300 --short-soak --lot REST --db " + db + " --quiet");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  return db;
}

std::string OnlyRunId(const std::string& db) {
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  auto s = (*a)->db().Prepare("SELECT run_id FROM runs");
  EXPECT_TRUE(*s->Step());
  return s->Text(0);
}

void Update(const std::string& db, const std::string& sql) {
  auto d = store::Db::Open(db, store::Db::Mode::kReadWrite);
  ASSERT_TRUE(d.ok());
  ASSERT_TRUE((*d)->Exec(sql).ok());
}

TEST(IntegrityTest, VerifyAndReanalyzeCheckNameAChunkAlteredAtRest) {
  testing::TempDir dir("integrity_rest");
  const std::string db = ArchiveOneRun(dir);
  const std::string run_id = OnlyRunId(db);
  const std::string verify = Bin("imuqual") + " verify --db " + db;
  const std::string check = Bin("imuqual") + " reanalyze " + run_id + " --db " + db + " --check";
  // GIVEN a clean archive: both say so
  ASSERT_EQ(RunCommand(verify).exit_code, 0);
  ASSERT_EQ(RunCommand(check).exit_code, 0);
  // WHEN chunk 5's data is replaced by chunk 6's (a valid chunk, so only its
  // checksum can tell) behind imuqual's back
  Update(db,
         "UPDATE raw_chunks SET data = (SELECT data FROM raw_chunks WHERE seq = 6) WHERE seq = 5");
  // THEN verify and the run's check name that chunk, and fail
  auto v = RunCommand(verify);
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_NE(v.output.find("run " + run_id + " chunk seq 5: damaged"), std::string::npos)
      << v.output;
  EXPECT_EQ(std::count(v.output.begin(), v.output.end(), '\n'), 1) << v.output;
  auto c = RunCommand(check);
  EXPECT_EQ(c.exit_code, 1) << c.output;
  EXPECT_NE(c.output.find("chunk seq 5: damaged"), std::string::npos) << c.output;
  // AND a result row altered the same way is found too.
  Update(db, "UPDATE measurements SET value = value * 1.0000001 WHERE name = 'bias_instability'");
  v = RunCommand(verify);
  EXPECT_EQ(v.exit_code, 1);
  EXPECT_NE(v.output.find("run " + run_id + " results: damaged"), std::string::npos) << v.output;
}

// Re-seals a run's results after they were changed: what a wrong value
// archived with a valid checksum looks like (only re-analysis can tell).
void ResealResults(const std::string& db, const std::string& run_id) {
  auto d = store::Db::Open(db, store::Db::Mode::kReadWrite);
  ASSERT_TRUE(d.ok());
  auto key = (*d)->QueryInt("SELECT run_key FROM runs WHERE run_id = '" + run_id + "'");
  ASSERT_TRUE(key.ok());
  ASSERT_TRUE(store::SealResults(**d, *key).ok());
}

// Real axis naming (gx gy gz ax ay az: not alphabetical) through the station,
// the archive and re-analysis: the check holds on every run; a curve point or
// a measurement changed (and re-sealed, so no checksum can tell) fails it,
// and it names the axis, the quantity and both values.
TEST(IntegrityTest, CheckHoldsOnASixAxisLotAndNamesAChangedPointOrMeasurement) {
  testing::TempDir dir("integrity_six");
  const std::string db = dir.path("six.db");
  const auto run = RunCommand(Bin("imuqual") + " run --sim 2 --profile tactical --duration 600 " +
                              "--lot SIX --db " + db + " --quiet 2>&1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::vector<std::string> ids;
  {
    auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
    ASSERT_TRUE(a.ok());
    auto s = (*a)->db().Prepare("SELECT run_id FROM runs ORDER BY run_id");
    while (*s->Step()) ids.push_back(s->Text(0));
    // The plan's axis order, not the alphabet's.
    auto axes = (*a)->db().Prepare("SELECT GROUP_CONCAT(axis, ' ') FROM (SELECT axis FROM "
                                   "run_axes WHERE run_key = 1 ORDER BY axis_index)");
    ASSERT_TRUE(*axes->Step());
    EXPECT_EQ(axes->Text(0), "gx gy gz ax ay az");
  }
  ASSERT_EQ(ids.size(), 2u);
  // The judged curve is the archived one: every axis's minimum (value and
  // tau) is a point of its archived curve, and every point carries its
  // chi-square interval and noise identification.
  {
    auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
    ASSERT_TRUE(a.ok());
    auto s = (*a)->db().Prepare(
        "SELECT r.run_id, m.axis, m.value, "
        "  (SELECT COUNT(*) FROM curve_points p WHERE p.run_key = m.run_key AND p.axis = m.axis "
        "     AND p.tau_s = m.value), "
        "  (SELECT COUNT(*) FROM curve_points p WHERE p.run_key = m.run_key AND p.axis = m.axis "
        "     AND (p.lo IS NULL OR p.hi IS NULL OR p.edf IS NULL OR p.alpha IS NULL)), "
        "  (SELECT COUNT(*) FROM curve_points p WHERE p.run_key = m.run_key AND p.axis = m.axis) "
        "FROM measurements m JOIN runs r USING (run_key) WHERE m.name = 'tau_at_minimum' "
        "ORDER BY r.run_id, m.axis");
    ASSERT_TRUE(s.ok());
    int axes_seen = 0;
    while (*s->Step()) {
      SCOPED_TRACE(s->Text(0) + " " + s->Text(1));
      EXPECT_EQ(s->Int(3), 1) << "tau_at_minimum " << s->Real(2) << " is not an archived point";
      EXPECT_EQ(s->Int(4), 0) << "points without interval or alpha";
      EXPECT_GT(s->Int(5), 40) << "not the dense judged curve";
      ++axes_seen;
    }
    EXPECT_EQ(axes_seen, 12);
  }
  // Export and report carry every axis by its name.
  const auto curves = RunCommand(Bin("imuqual") + " export --lot SIX --db " + db + " --as curves");
  ASSERT_EQ(curves.exit_code, 0) << curves.output;
  const auto measurements =
      RunCommand(Bin("imuqual") + " export --lot SIX --db " + db + " --as measurements");
  ASSERT_EQ(measurements.exit_code, 0) << measurements.output;
  const auto report = RunCommand(Bin("imuqual") + " report --lot SIX --db " + db + " -o " +
                                 dir.path("six.html") + " 2>&1");
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const auto read = ReadFileToString(dir.path("six.html"));
  ASSERT_TRUE(read.ok());
  const std::string& html = *read;
  for (const char* axis : {"gx", "gy", "gz", "ax", "ay", "az"}) {
    for (const std::string& id : ids) {
      const std::string row = "," + id + "," + axis + ",";
      EXPECT_NE(curves.output.find(row), std::string::npos) << "curves export lacks " << row;
      EXPECT_NE(measurements.output.find(row), std::string::npos)
          << "measurements export lacks " << row;
    }
    EXPECT_NE(html.find(std::string(">") + axis + "<"), std::string::npos) << "report lacks " << axis;
  }
  auto check = [&](const std::string& id) {
    return RunCommand(Bin("imuqual") + " reanalyze " + id + " --db " + db + " --check 2>&1 >/dev/null");
  };
  for (const std::string& id : ids) {
    const auto c = check(id);
    EXPECT_EQ(c.exit_code, 0) << id << ": " << c.output;
  }
  // WHEN one curve point of gz in the first run is changed
  Update(db, "UPDATE curve_points SET dev = dev * 1.001 WHERE axis = 'gz' AND m = 4 AND run_key = "
             "(SELECT run_key FROM runs WHERE run_id = '" + ids[0] + "')");
  ResealResults(db, ids[0]);
  auto c = check(ids[0]);
  EXPECT_EQ(c.exit_code, 1) << c.output;
  EXPECT_NE(c.output.find("axis gz, curve point"), std::string::npos) << c.output;
  EXPECT_NE(c.output.find("(m=4) dev: archived "), std::string::npos) << c.output;
  EXPECT_EQ(c.output.find("axis gx"), std::string::npos) << "only gz differs: " << c.output;
  // AND one measurement of ay in the second run
  Update(db, "UPDATE measurements SET value = value * 1.001 WHERE axis = 'ay' AND name = "
             "'bias_instability' AND run_key = (SELECT run_key FROM runs WHERE run_id = '" +
             ids[1] + "')");
  ResealResults(db, ids[1]);
  c = check(ids[1]);
  EXPECT_EQ(c.exit_code, 1) << c.output;
  EXPECT_NE(c.output.find("axis ay, bias_instability value: archived "), std::string::npos)
      << c.output;
  EXPECT_NE(c.output.find(", recomputed "), std::string::npos) << c.output;
}

// Overwrites `n` bytes at `offset` of `path` with 0xFF.
void Scribble(const std::string& path, std::streamoff offset, size_t n) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  ASSERT_TRUE(f.good());
  f.seekp(offset);
  const std::string junk(n, '\xFF');
  f.write(junk.data(), static_cast<std::streamsize>(n));
}

TEST(IntegrityTest, TheStoreRefusesADamagedArchiveAndVerifyReportsIt) {
  testing::TempDir dir("integrity_page");
  const std::string db = ArchiveOneRun(dir);
  // GIVEN a page in the middle of the file overwritten (its header and
  // first cells: what a torn or misdirected write leaves)
  const auto size = static_cast<std::streamoff>(std::filesystem::file_size(db));
  auto page = Query(db, "PRAGMA page_size");
  ASSERT_GT(size / page, 4);
  Scribble(db, (size / page / 2) * page, 64);
  const auto before = ReadFileToString(db);
  // WHEN a station's store opens it for writing
  auto run = RunCommand(Bin("imuqual-store") +
                        " --lcm-url 'udpm://239.255.76.67:7999?ttl=0' --db " + db + " 2>&1");
  // THEN it refuses with one line naming the file, and leaves it as it was
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(std::count(run.output.begin(), run.output.end(), '\n'), 1) << run.output;
  EXPECT_NE(run.output.find(db + " is damaged"), std::string::npos) << run.output;
  EXPECT_EQ(ReadFileToString(db).value(), before.value());
  // AND verify reports the damage.
  auto v = RunCommand(Bin("imuqual") + " verify --db " + db);
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_FALSE(v.output.empty());
}

}  // namespace
}  // namespace imuqual
