// Real data in: a recorded CSV replayed through the whole station, and a
// station run recorded with lcm-logger and replayed with lcm-logplayer into
// a fresh analyze and store.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include <unistd.h>

#include "acquire/imu_simulator.h"
#include "common/clock.h"
#include "common/strings.h"
#include "common/subprocess.h"
#include "common/text_util.h"
#include "store/archive.h"
#include "store/query.h"
#include "store/reanalysis.h"
#include "tests/station_harness.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::RunCommand;

constexpr double kRateHz = 100;
constexpr int kRows = 360000;  // one hour at 100 Hz

// CSV rows: a counter, then 3 gyro axes as doubles that are NOT float32
// values (the station must round them to float32 exactly once).
std::vector<std::vector<double>> MakeRecording() {
  pb::SimTruth truth;
  truth.set_seed(99);
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
  std::vector<std::vector<float>> y(3);
  sim->Generate(kRows, y);
  std::vector<std::vector<double>> axes(3);
  for (int a = 0; a < 3; ++a) {
    for (int k = 0; k < kRows; ++k) axes[a].push_back(y[a][k] + 1.234567e-11 * (k % 7 + 1));
  }
  return axes;
}

TEST(ReplayTest, CsvThroughTheStationArchivesFloat32ExactAndReanalysesAsAnalyze) {
  testing::TempDir dir("replay_csv");
  const std::vector<std::vector<double>> axes = MakeRecording();
  {
    std::ofstream csv(dir.path("record.csv"));
    csv << "time_s,count,gx,gy,gz\n";
    char line[160];
    for (int k = 0; k < kRows; ++k) {
      std::snprintf(line, sizeof line, "%.6f,%d,%.17g,%.17g,%.17g\n", k / kRateHz, 1000 + k,
                    axes[0][k], axes[1][k], axes[2][k]);
      csv << line;
    }
  }
  // GIVEN the recording replayed as unit R1 of lot CSV
  const std::string db = dir.path("replay.db");
  const auto run = RunCommand(Bin("imuqual") + " run --unit R1=csv:" + dir.path("record.csv") +
                              ",rate=100,counter=count,axes=gx:gyro/gy:gyro/gz:gyro --lot CSV --db " +
                              db + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // THEN every sample is archived, as the float32 nearest to the CSV value.
  auto archive = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok());
  store::RunFilter f;
  f.lot = "CSV";
  auto runs = store::QueryRuns(**archive, f);
  ASSERT_EQ(runs->size(), 1u);
  const std::string run_id = (*runs)[0].run_id;
  auto samples = store::LoadRunSamples(**archive, run_id);
  ASSERT_TRUE(samples.ok());
  EXPECT_EQ(samples->first_counter, 1000);
  for (int a = 0; a < 3; ++a) {
    ASSERT_EQ(samples->samples[a].size(), static_cast<size_t>(kRows));
    int exact = 0;
    for (int k = 0; k < kRows; ++k) exact += samples->samples[a][k] == static_cast<float>(axes[a][k]);
    EXPECT_EQ(exact, kRows) << "axis " << a;
  }
  // AND the exact re-analysis of the archive equals imuqual analyze of the
  // same float32-rounded data, row for row.
  const auto re = RunCommand(Bin("imuqual") + " reanalyze " + run_id + " --db " + db +
                             " --exact --stop none --format csv");
  ASSERT_EQ(re.exit_code, 0);
  std::map<std::string, std::vector<std::string>> re_rows;  // axis -> "tau,n,dev" rows
  {
    std::istringstream in(re.output);
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "axis,dev_type,m,tau,n,dev");
    while (std::getline(in, line)) {
      const auto cells = Split(line, ',');
      re_rows[cells[0]].push_back(cells[3] + "," + cells[4] + "," + cells[5]);
    }
  }
  const char* names[] = {"gx", "gy", "gz"};
  for (int a = 0; a < 3; ++a) {
    const std::string path = dir.path(std::string(names[a]) + ".txt");
    {
      std::ofstream out(path);
      char v[40];
      for (int k = 0; k < kRows; ++k) {
        // The archived float32 value, written exactly (a double holds every float).
        std::snprintf(v, sizeof v, "%.17g\n", static_cast<double>(static_cast<float>(axes[a][k])));
        out << v;
      }
    }
    const auto an = RunCommand(Bin("imuqual") + " analyze " + path + " --rate 100 --stop none --format csv");
    ASSERT_EQ(an.exit_code, 0);
    std::istringstream in(an.output);
    std::string line;
    std::getline(in, line);
    std::vector<std::string> rows;
    while (std::getline(in, line)) {
      const auto cells = Split(line, ',');
      rows.push_back(cells[2] + "," + cells[3] + "," + cells[4]);
    }
    EXPECT_EQ(rows, re_rows[names[a]]) << names[a];
    EXPECT_GT(rows.size(), 15u);
  }
}

// The absolute path of a program on PATH ("" if absent).
std::string Which(const std::string& program) {
  for (const std::string& dir : Split(std::getenv("PATH") ? std::getenv("PATH") : "", ':')) {
    const std::string path = dir + "/" + program;
    if (::access(path.c_str(), X_OK) == 0) return path;
  }
  return "";
}

// A lot's curves by "unit/axis".
std::map<std::string, std::vector<allan::CurvePoint>> CurvesOf(const std::string& db,
                                                               const std::string& lot = "LOGGED") {
  std::map<std::string, std::vector<allan::CurvePoint>> out;
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  EXPECT_TRUE(a.ok()) << a.status().ToString();
  store::RunFilter f;
  f.lot = lot;
  const auto runs = store::QueryRuns(**a, f);
  for (const store::RunRow& r : *runs) {
    const auto curves = (*a)->LoadCurves(**(*a)->FindRunKey(r.run_id));
    for (const store::CurveRecord& c : *curves) out[r.unit + "/" + c.axis] = c.curve.points;
  }
  return out;
}

// A lot's run ids by unit, and its measurements by "unit/axis/name".
std::map<std::string, std::string> RunsOf(const std::string& db, const std::string& lot) {
  std::map<std::string, std::string> out;
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  store::RunFilter f;
  f.lot = lot;
  const auto runs = store::QueryRuns(**a, f);
  for (const store::RunRow& r : *runs) out[r.unit] = r.run_id;
  return out;
}

std::map<std::string, double> MeasurementsOf(const std::string& db, const std::string& lot) {
  std::map<std::string, double> out;
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  for (const auto& [serial, run_id] : RunsOf(db, lot)) {
    auto result = (*a)->LoadResult(**(*a)->FindRunKey(run_id));
    EXPECT_TRUE(result.ok() && result->has_value()) << run_id;
    for (const pb::Measurement& m : (*result)->measurements) {
      out[serial + "/" + m.axis() + "/" + m.name()] = m.value();
    }
  }
  return out;
}

TEST(ReplayTest, StoredRunsReplayedFromTheArchiveGiveTheSameResults) {
  testing::TempDir dir("replay_archive");
  // GIVEN a lot soaked and archived
  const std::string original = dir.path("original.db");
  auto run = RunCommand(Bin("imuqual") + " run --sim 2 --duration 1800 --short-soak --lot ORIG --db " + original +
                        " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const auto runs = RunsOf(original, "ORIG");
  ASSERT_EQ(runs.size(), 2u);
  // WHEN its runs are re-run through a station from the archive's raw chunks
  std::string units;
  for (const auto& [serial, run_id] : runs) {
    units += " --unit " + serial + "=archive:" + original + ",run=" + run_id;
  }
  const std::string again = dir.path("again.db");
  run = RunCommand(Bin("imuqual") + " run" + units + " --lot AGAIN --db " + again +
                   " --plan builtin:vg700ca --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // THEN every curve point and every measurement (timing truth included:
  // the arrival times travel with the chunks) is the original's, bit for bit.
  const auto before = CurvesOf(original, "ORIG");
  const auto after = CurvesOf(again, "AGAIN");
  ASSERT_EQ(before.size(), 6u);
  ASSERT_EQ(after.size(), before.size());
  for (const auto& [key, points] : before) {
    const auto& other = after.at(key);
    ASSERT_EQ(other.size(), points.size()) << key;
    for (size_t p = 0; p < points.size(); ++p) {
      EXPECT_EQ(other[p].dev, points[p].dev) << key << " m=" << points[p].m;
    }
  }
  const auto m_before = MeasurementsOf(original, "ORIG");
  const auto m_after = MeasurementsOf(again, "AGAIN");
  ASSERT_TRUE(m_before.count("ORIG-U01//measured_rate"));
  EXPECT_EQ(m_after, m_before);
  // A run that is not there is a one-line error naming it.
  run = RunCommand(Bin("imuqual") + " run --unit X=archive:" + original +
                   ",run=NOPE --lot AGAIN --db " + again + " --quiet 2>&1");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("NOPE"), std::string::npos) << run.output;
}

TEST(ReplayTest, LoggedStationReplayedWithLcmLogplayerGivesTheLiveResults) {
  const std::string logger = Which("lcm-logger"), player = Which("lcm-logplayer");
  ASSERT_FALSE(logger.empty() || player.empty()) << "lcm-logger and lcm-logplayer (liblcm-bin) are needed";
  const std::string acquire_channels = "IMUQUAL5_(RUN|RAW\\..*)";
  // GIVEN a live station whose acquire traffic the standard logger records
  testing::StationHarness live("replay_live");
  const std::string log = live.path("station.lcmlog");
  {
    Subprocess store = live.StartStore();
    Subprocess analyze = live.StartAnalyze();
    auto rec = Subprocess::Start(
        {logger, "--lcm-url=" + live.url(), "--channel=" + acquire_channels, "-f", log}, live.log());
    ASSERT_TRUE(rec.ok());
    live.Pump(300);  // the logger subscribes
    Subprocess acquire = live.Start(
        "imuqual-acquire", {"--lot", "LOGGED", "--sim", "2", "--duration", "600", "--pace", "200",
                            "--await", "store,analyze", "--run-prefix", "LOG", "--plan",
                            "builtin:vg700ca"});
    ASSERT_TRUE(live.WaitRunsDone(2, 120)) << live.Logs();
    EXPECT_EQ(acquire.Wait(30), 0);
    EXPECT_EQ(rec->Stop(10), 0);  // SIGTERM: the logger closes its file
  }
  // WHEN the log is played, older than the freshness window, into a fresh
  // analyze and store that were not told to take a replay
  const double logged_at = MonotonicSeconds();
  {
    testing::StationHarness unasked("replay_unasked");
    Subprocess store = unasked.StartStore({"--stale-after", "30", "--max-message-age", "2"});
    Subprocess analyze = unasked.StartAnalyze({"--stale-after", "30", "--max-message-age", "2"});
    while (MonotonicSeconds() < logged_at + 3) unasked.Pump(100);  // the log is 3 s old at least
    auto play = Subprocess::Start({player, "--lcm-url=" + unasked.url(), "--regexp=" + acquire_channels, log},
                                  unasked.log());
    ASSERT_TRUE(play.ok());
    EXPECT_EQ(play->Wait(60), 0);
    // THEN nothing of it is taken: every message refused as replayed, counted
    EXPECT_GT(unasked.WaitCounter("store", "messages_replayed", 100, 10), 100) << unasked.Logs();
    EXPECT_GT(unasked.WaitCounter("analyze", "messages_replayed", 100, 10), 100) << unasked.Logs();
    EXPECT_TRUE(unasked.runs_done().empty());
    EXPECT_EQ(unasked.Counter("store", "runs_active"), 0);
  }
  // WHEN it is played into a fresh analyze and store told to take it
  // (--accept-replay), at half speed, and with the patience a log's pauses
  // need: nobody is there to resend what a busy host drops.
  testing::StationHarness replay("replay_played");
  Subprocess store = replay.StartStore({"--stale-after", "30", "--accept-replay"});
  Subprocess analyze = replay.StartAnalyze({"--stale-after", "30", "--accept-replay"});
  auto play = Subprocess::Start({player, "--lcm-url=" + replay.url(), "--speed=0.5",
                                 "--regexp=" + acquire_channels, log},
                                replay.log());
  ASSERT_TRUE(play.ok());
  ASSERT_TRUE(replay.WaitRunsDone(2, 120)) << replay.Logs();
  EXPECT_EQ(play->Wait(30), 0);
  // THEN its curves are the live ones, bit for bit.
  const auto live_curves = CurvesOf(live.db());
  const auto replayed = CurvesOf(replay.db());
  ASSERT_EQ(live_curves.size(), 6u);  // 2 units x 3 axes
  ASSERT_EQ(replayed.size(), live_curves.size());
  for (const auto& [key, points] : live_curves) {
    const auto& other = replayed.at(key);
    ASSERT_EQ(other.size(), points.size()) << key;
    for (size_t p = 0; p < points.size(); ++p) {
      EXPECT_EQ(other[p].dev, points[p].dev) << key << " m=" << points[p].m;
      EXPECT_EQ(other[p].n, points[p].n) << key;
    }
  }
}

}  // namespace
}  // namespace imuqual
