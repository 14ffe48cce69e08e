// The whole station over real LCM UDP multicast: imuqual run starts
// imuqual-store, imuqual-analyze and imuqual-acquire as separate processes
// (in a private network namespace when ctest can make one, else on a fresh
// port with ttl=0), soaks a small simulated lot, and the archive is checked
// against what was sent, against the analysis library run over the archived
// samples, and against the simulator's truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <numbers>
#include <sstream>

#include "common/text_util.h"
#include "imuqual/sim.pb.h"
#include "store/archive.h"
#include "store/reanalysis.h"
#include "tests/test_util.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::RunCommand;

constexpr int kUnits = 8;               // the 8th unit of a vg700 lot is a planted failure
constexpr double kDurationS = 1200;
constexpr double kRateHz = 100;
constexpr char kLot[] = "ITEST";
constexpr double kBiasLimitDegH = 20;

// The vg700ca limits with a minimum duration the short soak meets.
constexpr char kPlan[] = R"pb(
name: "itest"
axes { name: "x" kind: GYRO }
axes { name: "y" kind: GYRO }
axes { name: "z" kind: GYRO }
nominal_rate_hz: 100
min_duration_s: 600
warmup_s: 60
grid { kind: OCTAVE }
limits { measurement: "bias_instability" axis_kind: GYRO high: 20 marginal_high: 16 unit: "deg/h" }
limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.8 unit: "deg/sqrt(h)" }
limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
)pb";

class StationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir("station_test");
    db_ = dir_->path("station.db");
    const std::string plan = dir_->path("plan.textproto");
    std::ofstream(plan) << kPlan;
    std::ostringstream cmd;
    cmd << Bin("imuqual") << " run --sim " << kUnits << " --duration " << kDurationS
        << " --rate " << kRateHz << " --lot " << kLot << " --db " << db_ << " --plan " << plan
        << " --quiet";
    run_ = new testing::CommandResult(RunCommand(cmd.str()));
  }
  static void TearDownTestSuite() {
    delete run_;
    delete dir_;
  }

  static std::unique_ptr<store::Archive> Open() {
    auto a = store::Archive::Open(db_, store::Archive::Mode::kRead);
    EXPECT_TRUE(a.ok()) << a.status().ToString();
    return a.ok() ? std::move(*a) : nullptr;
  }

  static std::vector<std::string> RunIds(store::Archive& a) {
    std::vector<std::string> ids;
    auto s = a.db().Prepare("SELECT run_id FROM runs WHERE lot = ? ORDER BY serial");
    EXPECT_TRUE(s.ok());
    s->Bind(1, std::string(kLot));
    while (*s->Step()) ids.push_back(s->Text(0));
    return ids;
  }

  static testing::TempDir* dir_;
  static std::string db_;
  static testing::CommandResult* run_;
};

testing::TempDir* StationTest::dir_ = nullptr;
std::string StationTest::db_;
testing::CommandResult* StationTest::run_ = nullptr;

TEST_F(StationTest, RunEndsCleanlyWithATable) {
  ASSERT_EQ(run_->exit_code, 0) << run_->output;
  EXPECT_NE(run_->output.find("8 units:"), std::string::npos) << run_->output;
  // Gyros only: the headers carry the units.
  EXPECT_NE(run_->output.find("BI deg/h"), std::string::npos) << run_->output;
  EXPECT_NE(run_->output.find("ARW deg/sqrt(h)"), std::string::npos) << run_->output;
  // The final table is in fixture order, the slot first.
  EXPECT_NE(run_->output.find("slot  serial"), std::string::npos) << run_->output;
}

TEST_F(StationTest, EveryBatchIsArchivedWithoutGaps) {
  auto a = Open();
  ASSERT_TRUE(a);
  const std::vector<std::string> ids = RunIds(*a);
  ASSERT_EQ(ids.size(), static_cast<size_t>(kUnits));
  for (const std::string& id : ids) {
    auto run = a->LoadRun(id);
    ASSERT_TRUE(run.ok());
    EXPECT_EQ(run->state, "complete") << id;
    EXPECT_EQ(run->samples_announced, static_cast<int64_t>(kDurationS * kRateHz)) << id;
    auto key = a->FindRunKey(id);
    int64_t chunks = 0, samples = 0, next_seq = 0, next_counter = 0;
    ASSERT_TRUE(a->ForEachChunk(**key, [&](const store::ChunkRecord& c) {
                   // Consecutive seqs and device counters, nothing twice, nothing missing.
                   EXPECT_EQ(c.seq, next_seq++);
                   EXPECT_EQ(c.first_sample, next_counter);
                   next_counter += c.num_samples;
                   ++chunks;
                   samples += c.num_samples;
                   return Status::Ok();
                 }).ok());
    EXPECT_EQ(chunks, run->last_seq + 1) << id;
    EXPECT_EQ(samples, run->samples_announced) << id;
    auto gaps = a->LoadGaps(**key);
    ASSERT_TRUE(gaps.ok());
    EXPECT_TRUE(gaps->empty()) << id;
  }
}

TEST_F(StationTest, ArchivedResultEqualsReanalysisOfArchivedSamples) {
  auto a = Open();
  ASSERT_TRUE(a);
  for (const std::string& id : RunIds(*a)) {
    auto outcome = store::ReanalyzeRun(*a, id);
    ASSERT_TRUE(outcome.ok()) << outcome.status().ToString();
    auto key = a->FindRunKey(id);
    auto curves = a->LoadCurves(**key);
    ASSERT_TRUE(curves.ok());
    ASSERT_EQ(curves->size(), outcome->curves.size()) << id;
    for (size_t i = 0; i < curves->size(); ++i) {
      // Bit for bit: the same code over the same float32 samples.
      const allan::Curve& live = (*curves)[i].curve;
      const auto& [axis, again] = outcome->curves[i];
      ASSERT_EQ((*curves)[i].axis, axis);
      ASSERT_EQ(live.points.size(), again.points.size()) << id << " " << axis;
      ASSERT_GT(live.points.size(), 8u);
      for (size_t p = 0; p < live.points.size(); ++p) {
        EXPECT_EQ(live.points[p].m, again.points[p].m);
        EXPECT_EQ(live.points[p].tau_s, again.points[p].tau_s);
        EXPECT_EQ(live.points[p].dev, again.points[p].dev) << id << " " << axis << " m=" << live.points[p].m;
        EXPECT_EQ(live.points[p].lo, again.points[p].lo);
        EXPECT_EQ(live.points[p].hi, again.points[p].hi);
        EXPECT_EQ(live.points[p].n, again.points[p].n);
        EXPECT_EQ(live.points[p].stride, again.points[p].stride);
      }
    }
    // The archived measurements are the re-analysed ones.
    auto s = a->db().Prepare("SELECT axis, name, value FROM measurements WHERE run_key = ?");
    s->Bind(1, **key);
    int compared = 0;
    while (*s->Step()) {
      for (const pb::Measurement& m : outcome->measurements) {
        if (m.axis() == s->Text(0) && m.name() == s->Text(1)) {
          if (std::isnan(m.value())) {
            EXPECT_TRUE(std::isnan(s->Real(2)));
          } else {
            EXPECT_EQ(m.value(), s->Real(2)) << id << " " << m.axis() << " " << m.name();
          }
          ++compared;
        }
      }
    }
    EXPECT_EQ(compared, static_cast<int>(outcome->measurements.size())) << id;
  }
}

// The IEEE 952 model's curve minimum for a simulated axis's truth, deg/h.
double ModelMinimumDegH(const pb::AxisTruth& t) {
  const double k_flicker = 2 * std::numbers::ln2 / std::numbers::pi;
  double best = 1e300;
  for (double tau = 0.01; tau < 1e4; tau *= 1.01) {
    const double avar = 3 * t.quantization() * t.quantization() / (tau * tau) +
                        t.random_walk() * t.random_walk() / tau +
                        k_flicker * t.bias_instability() * t.bias_instability() +
                        t.rate_random_walk() * t.rate_random_walk() * tau / 3;
    best = std::min(best, std::sqrt(avar));
  }
  return best * 3600;
}

TEST_F(StationTest, VerdictsFollowTheSimulatedTruth) {
  auto a = Open();
  ASSERT_TRUE(a);
  int failing_units = 0;
  for (const std::string& id : RunIds(*a)) {
    auto run = a->LoadRun(id);
    pb::SimTruth truth;
    ASSERT_TRUE(truth.ParseFromString(run->truth)) << id;
    auto s = a->db().Prepare("SELECT COALESCE(verdict, ''), COALESCE(reasons, '') FROM runs WHERE run_id = ?");
    s->Bind(1, id);
    ASSERT_TRUE(*s->Step());
    const std::string verdict = s->Text(0), reasons = s->Text(1);
    bool expect_fail = false;
    for (const pb::AxisTruth& axis : truth.axes()) {
      const double model = ModelMinimumDegH(axis);
      // A 20-minute soak estimates the minimum to within ~10% (hundreds of
      // clusters at 10-30 s); 25% either side of the limit is unambiguous.
      const std::string reason = axis.axis() + ": bias_instability";
      if (model > kBiasLimitDegH * 1.25) {
        expect_fail = true;
        EXPECT_NE(reasons.find(reason), std::string::npos) << id << " model " << model;
      } else if (model < kBiasLimitDegH / 1.25) {
        EXPECT_EQ(reasons.find(reason + " "), std::string::npos) << id << " model " << model;
      }
    }
    if (expect_fail) {
      ++failing_units;
      EXPECT_EQ(verdict, "FAIL") << id;
    } else {
      EXPECT_NE(verdict, "") << id;
    }
  }
  EXPECT_EQ(failing_units, 1);  // the planted failure
}

TEST_F(StationTest, LotQueryAsCsv) {
  const auto r = RunCommand(Bin("imuqual") + " lot " + kLot + " --db " + db_ + " --format csv");
  ASSERT_EQ(r.exit_code, 0);
  std::istringstream in(r.output);
  std::string header;
  std::getline(in, header);
  const std::vector<std::string> cols = Split(header, ',');
  auto col = [&](const std::string& name) {
    return std::find(cols.begin(), cols.end(), name) - cols.begin();
  };
  for (const char* name : {"serial", "axis", "arw_deg_rt_hr", "bias_instability_deg_hr", "tau_min_s",
                           "gap_samples", "verdict"}) {
    EXPECT_LT(col(name), static_cast<long>(cols.size())) << name;
  }
  int rows = 0;
  for (std::string line; std::getline(in, line);) {
    const std::vector<std::string> cells = Split(line, ',');
    ASSERT_EQ(cells.size(), cols.size()) << line;
    EXPECT_EQ(cells[col("gap_samples")], "0");
    EXPECT_GT(std::stod(cells[col("bias_instability_deg_hr")]), 0);
    ++rows;
  }
  EXPECT_EQ(rows, kUnits * 3);
  // Unknown lot: a clear error and a non-zero exit.
  EXPECT_NE(RunCommand(Bin("imuqual") + " lot NOPE --db " + db_ + " 2>/dev/null").exit_code, 0);
}

// The station's final table lists the units in slot order (the order of
// --unit), not by serial, with the slot first, so that the operator finds
// each unit's fixture.
TEST(StationTableTest, FinalTableIsInSlotOrder) {
  testing::TempDir dir("station_slots");
  // (On an 80-column screen: COLUMNS stands for the terminal's width.)
  const auto run = RunCommand("COLUMNS=80 " + Bin("imuqual") +
                              " run --unit ZED=sim:vg700,index=0 --unit ALF=sim:vg700,index=1 "
                              "--duration 30 --lot SLOTS --db " +
                              dir.path("s.db") + " --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // Every line fits 80 columns (whole columns left out, named; text wrapped
  // at words), so a terminal never wraps a row mid-number.
  std::istringstream lines(run.output);
  for (std::string line; std::getline(lines, line);) {
    const bool one_word = line.find(' ', line.find_first_not_of(' ')) == std::string::npos;
    // Columns: code points (UTF-8 continuation bytes take none).
    const auto columns = std::count_if(line.begin(), line.end(), [](char c) {
      return (static_cast<unsigned char>(c) & 0xC0) != 0x80;
    });
    if (!one_word) {
      EXPECT_LE(columns, 80) << line << "\n" << run.output;
    }
  }
  EXPECT_NE(run.output.find("left out for 80 columns:"), std::string::npos) << run.output;
  const size_t zed = run.output.find("\n1     ZED");
  const size_t alf = run.output.find("\n2     ALF");
  ASSERT_NE(zed, std::string::npos) << run.output;
  ASSERT_NE(alf, std::string::npos) << run.output;
  EXPECT_LT(zed, alf);
}

// --fail-exit: a FAIL verdict makes the exit code 5 (for a script or a line
// controller); a lot that passes still exits 0, and without the flag a FAIL
// is a result (0).
TEST(StationTableTest, FailExitIsFiveOnlyWhenAUnitFails) {
  testing::TempDir dir("station_fail_exit");
  auto plan = [&](const char* name, double high) {
    const std::string path = dir.path(std::string(name) + ".textproto");
    std::ofstream(path) << "name: \"" << name << "\"\n"
                        << "axes { name: \"x\" kind: GYRO }\naxes { name: \"y\" kind: GYRO }\n"
                        << "axes { name: \"z\" kind: GYRO }\nnominal_rate_hz: 100\n"
                        << "min_duration_s: 0\nwarmup_s: 0\n"
                        << "limits { measurement: \"bias_instability\" axis_kind: GYRO high: " << high
                        << " unit: \"deg/h\" }\n";
    return path;
  };
  const std::string strict = plan("strict", 0.001), loose = plan("loose", 1e6);
  auto run = [&](const std::string& plan_path, const std::string& lot, const char* flag) {
    return RunCommand(Bin("imuqual") + " run --unit U1=sim:vg700,index=0 --duration 120 --lot " +
                      lot + " --db " + dir.path("f.db") + " --plan " + plan_path + " --quiet " +
                      flag);
  };
  const auto failed = run(strict, "F1", "--fail-exit");
  EXPECT_EQ(failed.exit_code, 5) << failed.output;
  EXPECT_NE(failed.output.find("1 FAIL"), std::string::npos) << failed.output;
  const auto passed = run(loose, "F2", "--fail-exit");
  EXPECT_EQ(passed.exit_code, 0) << passed.output;
  EXPECT_NE(passed.output.find("1 PASS"), std::string::npos) << passed.output;
  const auto plain = run(strict, "F3", "");
  EXPECT_EQ(plain.exit_code, 0) << plain.output;
}

}  // namespace
}  // namespace imuqual
