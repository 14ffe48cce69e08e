// Scale-out: three analyze processes, each taking its shard of the units,
// give exactly the results of one analyze taking them all; every unit is
// analysed by exactly one shard. Station identity: two stations on one bus
// keep to their own runs.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <tuple>

#include "common/clock.h"
#include "store/archive.h"
#include "tests/station_harness.h"

namespace imuqual {
namespace {

using testing::StationHarness;

constexpr double kRunTimeoutS = 180;
constexpr int kUnits = 9;

std::vector<std::string> AcquireArgs(const std::string& prefix) {
  return {"--lot", "SHARD", "--profile", "tactical", "--sim", std::to_string(kUnits), "--duration",
          "900", "--await", "store,analyze", "--run-prefix", prefix, "--seed", "11", "--plan",
          "builtin:tactical"};
}

// Every curve point and measurement of the lot's runs, by unit, axis and
// name (run ids differ between the two stations).
struct Results {
  std::map<std::string, std::vector<double>> curves;
  std::map<std::string, double> measurements;
  std::map<std::string, std::string> verdicts;
};

Results Load(const std::string& db, const std::string& prefix) {
  Results r;
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  EXPECT_TRUE(a.ok());
  for (int u = 1; u <= kUnits; ++u) {
    char serial[32];
    std::snprintf(serial, sizeof serial, "SHARD-U%02d", u);
    auto key = (*a)->FindRunKey(prefix + "-" + serial);
    EXPECT_TRUE(key.ok() && key->has_value()) << serial;
    if (!key.ok() || !key->has_value()) continue;
    const auto curves = (*a)->LoadCurves(**key);
    EXPECT_TRUE(curves.ok());
    if (!curves.ok()) continue;
    for (const store::CurveRecord& c : *curves) {
      for (const allan::CurvePoint& p : c.curve.points) r.curves[std::string(serial) + "/" + c.axis].push_back(p.dev);
    }
    auto result = (*a)->LoadResult(**key);
    EXPECT_TRUE(result.ok() && result->has_value()) << serial;
    if (!result.ok() || !result->has_value()) continue;
    r.verdicts[serial] = (*result)->verdict;
    for (const pb::Measurement& m : (*result)->measurements) {
      r.measurements[std::string(serial) + "/" + m.axis() + "/" + m.name()] = m.value();
    }
  }
  return r;
}

TEST(ShardTest, ThreeAnalyzeShardsGiveTheResultsOfOne) {
  // GIVEN a lot analysed by one analyze process
  StationHarness one("shard_one");
  {
    Subprocess store = one.StartStore();
    Subprocess analyze = one.StartAnalyze();
    Subprocess acquire = one.Start("imuqual-acquire", AcquireArgs("ONE"));
    ASSERT_TRUE(one.WaitRunsDone(kUnits, kRunTimeoutS)) << one.Logs();
    EXPECT_EQ(acquire.Wait(30), 0);
  }
  // WHEN the same lot is analysed by three shards
  StationHarness three("shard_three");
  Subprocess store = three.StartStore();
  std::vector<Subprocess> shards;
  for (int k = 0; k < 3; ++k) {
    shards.push_back(three.StartAnalyze({"--shard", std::to_string(k) + "/3"}));
  }
  Subprocess acquire = three.Start("imuqual-acquire", AcquireArgs("THREE"));
  ASSERT_TRUE(three.WaitRunsDone(kUnits, kRunTimeoutS)) << three.Logs();
  EXPECT_EQ(acquire.Wait(30), 0);
  // THEN every curve point, measurement and verdict is the same, bit for bit
  const Results a = Load(one.db(), "ONE");
  const Results b = Load(three.db(), "THREE");
  ASSERT_EQ(a.curves.size(), static_cast<size_t>(kUnits * 6));
  EXPECT_EQ(b.curves, a.curves);
  EXPECT_EQ(b.measurements, a.measurements);
  EXPECT_EQ(b.verdicts, a.verdicts);
  // AND the work was split: every shard finished some runs, together each
  // run once (their status reports come about once a second).
  auto finished = [&](int k) { return three.CounterOf(shards[k].pid(), "runs_finished"); };
  const double deadline = MonotonicSeconds() + 10;
  while (finished(0) + finished(1) + finished(2) < kUnits && MonotonicSeconds() < deadline) three.Pump(100);
  for (int k = 0; k < 3; ++k) EXPECT_GT(finished(k), 0) << "shard " << k << " analysed nothing";
  EXPECT_EQ(finished(0) + finished(1) + finished(2), kUnits);
}

// Two stations forced onto one bus: each store and analyze serves its own
// station id, archives and judges exactly that station's runs (although both
// soak the same lot, hence the same serials), and counts the other's as
// foreign instead of archiving or analysing them.
TEST(StationIdentityTest, TwoStationsOnOneBusKeepTheirOwnRuns) {
  constexpr int kUnitsEach = 3;
  StationHarness bus("two_stations");
  const std::string db_b = bus.path("b.db");
  Subprocess store_a = bus.StartStore({"--station", "A"});
  Subprocess store_b = bus.StartStore({"--station", "B", "--db", db_b});
  Subprocess analyze_a = bus.StartAnalyze({"--station", "A"});
  Subprocess analyze_b = bus.StartAnalyze({"--station", "B"});
  auto acquire_args = [](const std::string& station, const std::string& prefix) {
    return std::vector<std::string>{"--lot", "TWIN", "--profile", "tactical", "--sim",
                                    std::to_string(kUnitsEach), "--duration", "300", "--await",
                                    "store,analyze", "--run-prefix", prefix, "--station", station,
                                    "--plan", "builtin:tactical"};
  };
  Subprocess acquire_a = bus.Start("imuqual-acquire", acquire_args("A", "RUN-A"));
  Subprocess acquire_b = bus.Start("imuqual-acquire", acquire_args("B", "RUN-B"));
  ASSERT_TRUE(bus.WaitRunsDone(2 * kUnitsEach, kRunTimeoutS)) << bus.Logs();
  EXPECT_EQ(acquire_a.Wait(30), 0);
  EXPECT_EQ(acquire_b.Wait(30), 0);
  for (const auto& [db, own, other] : {std::tuple{bus.db(), "RUN-A", "RUN-B"},
                                       std::tuple{db_b, "RUN-B", "RUN-A"}}) {
    auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
    ASSERT_TRUE(a.ok()) << a.status().ToString();
    for (int u = 1; u <= kUnitsEach; ++u) {
      char serial[32];
      std::snprintf(serial, sizeof serial, "TWIN-U%02d", u);
      auto mine = (*a)->FindRunKey(std::string(own) + "-" + serial);
      ASSERT_TRUE(mine.ok() && mine->has_value()) << db << " lacks its run of " << serial;
      auto result = (*a)->LoadResult(**mine);
      ASSERT_TRUE(result.ok() && result->has_value()) << serial << " not judged in " << db;
      EXPECT_FALSE((*result)->verdict.empty()) << serial;
      auto theirs = (*a)->FindRunKey(std::string(other) + "-" + serial);
      ASSERT_TRUE(theirs.ok());
      EXPECT_FALSE(theirs->has_value()) << db << " archived the other station's run of " << serial;
    }
  }
  // Each process saw the other station's runs and counted them.
  const double deadline = MonotonicSeconds() + 10;
  auto counted = [&] {
    for (pid_t pid : {store_a.pid(), store_b.pid(), analyze_a.pid(), analyze_b.pid()}) {
      if (bus.CounterOf(pid, "foreign_runs") < kUnitsEach) return false;
    }
    return true;
  };
  while (!counted() && MonotonicSeconds() < deadline) bus.Pump(100);
  for (pid_t pid : {store_a.pid(), store_b.pid(), analyze_a.pid(), analyze_b.pid()}) {
    EXPECT_EQ(bus.CounterOf(pid, "foreign_runs"), kUnitsEach) << "pid " << pid;
  }
}

}  // namespace
}  // namespace imuqual
