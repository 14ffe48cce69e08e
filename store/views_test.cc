// The archive's views (store/SCHEMA.md) against what the C++ computes:
// lot_measurements holds what `imuqual lot --stats` reads
// (QueryLotMeasurements), lot_statistics's sd agrees with a two-pass
// computation for any mean, and a schema-4 archive gets the new views.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <tuple>

#include "common/text_util.h"
#include "store/archive.h"
#include "store/checksums.h"
#include "store/query.h"
#include "store/schema.h"

namespace imuqual::store {
namespace {

namespace fs = std::filesystem;

// Schema 4's two measurement views as migration 0 -> 1 created them, to make
// a file of that schema.
constexpr char kSchema4MeasurementViews[] = R"sql(
DROP VIEW lot_statistics;
DROP VIEW lot_measurements;
DROP VIEW all_runs_measurements;
CREATE VIEW lot_measurements AS
SELECT r.lot, r.serial AS unit, r.run_id, r.start_utime, m.axis,
       COALESCE(ra.kind, '') AS kind, m.name, m.value, m.unit, m.low, m.high,
       m.marginal_low, m.marginal_high, m.outcome
FROM measurements m
JOIN runs r ON r.run_key = m.run_key
LEFT JOIN run_axes ra ON ra.run_key = m.run_key AND ra.axis = m.axis;
CREATE VIEW lot_statistics AS
SELECT lot, kind, name, unit, COUNT(value) AS n, AVG(value) AS mean,
       SQRT(MAX(AVG(value * value) - AVG(value) * AVG(value), 0) * COUNT(value) / NULLIF(COUNT(value) - 1, 0)) AS sd,
       MIN(value) AS min, MAX(value) AS max,
       1.0 * SUM(outcome IN ('PASS', 'MARGINAL')) / NULLIF(SUM(outcome IS NOT NULL), 0) AS pass_rate
FROM lot_measurements GROUP BY lot, kind, name, unit;
)sql";

pb::Measurement Value(const std::string& axis, const std::string& name, double value,
                      const std::string& unit, pb::Outcome outcome = pb::OUTCOME_UNSET) {
  pb::Measurement m;
  m.set_axis(axis);
  m.set_name(name);
  m.set_value(value);
  m.set_unit(unit);
  if (outcome != pb::OUTCOME_UNSET) m.set_outcome(outcome);
  return m;
}

class ViewsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("imuqual_views_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    path_ = (dir_ / "a.db").string();
    auto a = Archive::Open(path_, Archive::Mode::kWrite);
    ASSERT_TRUE(a.ok()) << a.status().ToString();
    archive_ = std::move(*a);
  }
  void TearDown() override {
    archive_.reset();
    fs::remove_all(dir_);
  }

  // A run of `serial` in lot L with a gyro axis gx and an accelerometer ax,
  // judged with `values` unless `state` says it is still running.
  void AddRun(const std::string& run_id, const std::string& serial, int64_t start_utime,
              const std::string& state, std::vector<pb::Measurement> values) {
    RunInfo r;
    r.run_id = run_id;
    r.serial = serial;
    r.lot = "L";
    r.start_utime = start_utime;
    r.nominal_rate_hz = 100;
    r.axes = {{"gx", pb::GYRO}, {"ax", pb::ACCEL}};
    r.state = state;
    auto key = archive_->UpsertRun(r);
    ASSERT_TRUE(key.ok()) << key.status().ToString();
    if (state == "running" || values.empty()) return;
    ResultRecord res;
    res.verdict = "PASS";
    for (const pb::Measurement& m : values) {
      if (m.outcome() == pb::FAIL) res.verdict = "FAIL";
    }
    res.measurements = std::move(values);
    res.result_utime = start_utime + 1;
    ASSERT_TRUE(archive_->PutResult(*key, res).ok());
  }

  double Real(const std::string& sql) {
    auto s = archive_->db().Prepare(sql);
    EXPECT_TRUE(s.ok()) << s.status().ToString();
    if (!s.ok()) return NAN;
    auto row = s->Step();
    EXPECT_TRUE(row.ok() && *row) << sql;
    return row.ok() && *row ? s->Real(0) : NAN;
  }

  fs::path dir_;
  std::string path_;
  std::unique_ptr<Archive> archive_;
};

TEST_F(ViewsTest, LotMeasurementsHoldWhatLotStatsReads) {
  // GIVEN U1 tested twice (failed, then passed), U2 whose retest is still
  // running, U3 tested once (its gyro value not finite), U4 aborted unjudged
  AddRun("U1-R1", "U1", 1000, "complete",
         {Value("gx", "bias_instability", 9, "deg/h", pb::FAIL),
          Value("ax", "bias_instability", 40, "ug", pb::PASS), Value("", "duration", 7200, "s"),
          Value("gx", "model_white_noise", 0.1, "deg/sqrt(h)")});
  AddRun("U1-R2", "U1", 5000, "complete",
         {Value("gx", "bias_instability", 2, "deg/h", pb::PASS),
          Value("ax", "bias_instability", 30, "ug", pb::PASS), Value("", "duration", 7200, "s"),
          Value("gx", "model_white_noise", 0.1, "deg/sqrt(h)")});
  AddRun("U2-R1", "U2", 2000, "complete",
         {Value("gx", "bias_instability", 3, "deg/h", pb::PASS),
          Value("ax", "bias_instability", 35, "ug", pb::PASS), Value("", "duration", 7200, "s")});
  AddRun("U2-R2", "U2", 6000, "running", {});
  AddRun("U3-R1", "U3", 3000, "complete",
         {Value("gx", "bias_instability", INFINITY, "deg/h", pb::FAIL),
          Value("ax", "bias_instability", 20, "ug", pb::PASS), Value("", "duration", 3600, "s")});
  AddRun("U4-R1", "U4", 4000, "aborted", {});

  // WHEN the views and the query behind `imuqual lot --stats` are read
  using Key = std::tuple<std::string, std::string, std::string, std::string>;
  std::set<Key> view, all_runs, stats_input;
  for (auto [sql, out] :
       {std::pair{"SELECT serial, run_id, axis, name FROM lot_measurements "
                  "WHERE lot = 'L'",
                  &view},
        {"SELECT serial, run_id, axis, name FROM all_runs_measurements", &all_runs}}) {
    auto s = archive_->db().Prepare(sql);
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    while (*s->Step()) out->insert({s->Text(0), s->Text(1), s->Text(2), s->Text(3)});
  }
  auto rows = QueryLotMeasurements(*archive_, "L");
  ASSERT_TRUE(rows.ok()) << rows.status().ToString();
  for (const MeasurementRow& r : *rows) stats_input.insert({r.unit, r.run_id, r.axis, r.name});

  // THEN lot_measurements is that population, each unit's final run: U1's
  // retest, U2's judged run (its retest is not judged yet), U3; not U4,
  // never judged; all_runs_measurements has every judged run
  EXPECT_EQ(view, stats_input);
  std::set<std::string> runs, every_run;
  for (const Key& k : view) runs.insert(std::get<1>(k));
  for (const Key& k : all_runs) every_run.insert(std::get<1>(k));
  EXPECT_EQ(runs, (std::set<std::string>{"U1-R2", "U2-R1", "U3-R1"}));
  EXPECT_EQ(every_run, (std::set<std::string>{"U1-R1", "U1-R2", "U2-R1", "U3-R1"}));
  // AND a row says which unit (serial) and in what unit the value is
  auto s = archive_->db().Prepare(
      "SELECT serial, unit FROM lot_measurements WHERE run_id = 'U1-R2' AND axis = 'ax'");
  ASSERT_TRUE(s.ok() && *s->Step());
  EXPECT_EQ(s->Text(0), "U1");
  EXPECT_EQ(s->Text(1), "ug");
  // AND lot_statistics counts finite values as lot --stats does (U3's
  // infinite one is judged but has no number), one row per lot, kind,
  // measurement and unit, without the units' own model parameters
  EXPECT_EQ(Real("SELECT n FROM lot_statistics WHERE kind = 'gyro' AND name = 'bias_instability'"),
            2);
  EXPECT_EQ(
      Real("SELECT mean FROM lot_statistics WHERE kind = 'gyro' AND name = 'bias_instability'"),
      2.5);
  EXPECT_EQ(Real("SELECT pass_rate FROM lot_statistics "
                 "WHERE kind = 'gyro' AND name = 'bias_instability'"),
            2.0 / 3);
  EXPECT_NEAR(
      Real("SELECT sd FROM lot_statistics WHERE kind = 'gyro' AND name = 'bias_instability'"),
      std::sqrt(0.5), 1e-15);
  EXPECT_EQ(Real("SELECT n FROM lot_statistics WHERE kind = 'accel'"), 3);
  EXPECT_EQ(Real("SELECT mean FROM lot_statistics WHERE kind = 'accel'"), (30 + 35 + 20) / 3.0);
  EXPECT_EQ(Real("SELECT COUNT(*) FROM lot_statistics"), 3);  // gyro, accel, run-level duration
}

// sd over values 1e9 + N(0, 0.5^2): each x^2 is ~1e18, rounded to 128, far
// more than the variance (0.25) that mean(x^2) - mean(x)^2 should leave; the
// two-pass form subtracts the mean first and keeps every digit.
TEST_F(ViewsTest, LotStatisticsSdIsStableForALargeMean) {
  // GIVEN 40 units whose gyro offset is 1e9 deg/h plus a small spread
  constexpr double kOffset = 1e9;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> spread(0, 0.5);
  std::vector<double> values;
  ASSERT_TRUE(archive_->Begin().ok());
  for (int u = 0; u < 40; ++u) {
    values.push_back(kOffset + spread(rng));
    const std::string serial = std::string("U") + std::to_string(u);
    AddRun(serial + "-R1", serial, 1000 + u, "complete",
           {Value("gx", "bias_offset", values.back(), "deg/h", pb::PASS)});
  }
  ASSERT_TRUE(archive_->Commit().ok());
  // WHEN the view and a two-pass computation here give mean and sd
  double mean = 0;
  for (double v : values) mean += v;
  mean /= static_cast<double>(values.size());
  double ss = 0;
  for (double v : values) ss += (v - mean) * (v - mean);
  const double sd = std::sqrt(ss / static_cast<double>(values.size() - 1));
  const std::string where = " FROM lot_statistics WHERE lot = 'L' AND name = 'bias_offset'";
  // THEN they agree. The means may differ by a few ulps of 1e9 (summation
  // order); sd depends on the mean only to second order: 1e-12 relative.
  constexpr double kMeanUlps = 8 * 1.2e-7;  // ulp(1e9) = 2^-23
  constexpr double kSdRelative = 1e-12;
  EXPECT_NEAR(Real("SELECT mean" + where), mean, kMeanUlps);
  EXPECT_NEAR(Real("SELECT sd" + where), sd, kSdRelative * sd);
  EXPECT_NEAR(sd, 0.5, 0.15);  // the spread planted (40 values: +-20 % at 2 sigma)
  // AND the one-pass formula of schema 4 is wrong on these very values
  // (off by more than half the spread itself: these values do tell them apart)
  const double one_pass = Real(
      "SELECT SQRT(MAX(AVG(value * value) - AVG(value) * AVG(value), 0) * COUNT(value) / "
      "(COUNT(value) - 1)) FROM measurements WHERE name = 'bias_offset'");
  EXPECT_GT(std::abs(one_pass - sd), 0.5 * sd) << "one-pass sd " << one_pass << " vs " << sd;
}

// A file at schema 4 (its measurement views as they were, the others
// stand-ins) is migrated to views identical to a new archive's, and its
// statistics become those of each unit's latest run.
TEST_F(ViewsTest, MigrationFromSchema4ReplacesEveryView) {
  // GIVEN U1 tested twice and U2 once, in an archive as schema 4 kept it
  AddRun("U1-R1", "U1", 1000, "complete", {Value("gx", "bias_instability", 9, "deg/h", pb::FAIL)});
  AddRun("U1-R2", "U1", 5000, "complete", {Value("gx", "bias_instability", 2, "deg/h", pb::PASS)});
  AddRun("U2-R1", "U2", 2000, "complete", {Value("gx", "bias_instability", 4, "deg/h", pb::PASS)});
  auto views_of = [](Db& db) {
    std::set<std::pair<std::string, std::string>> out;
    auto s = db.Prepare("SELECT name, sql FROM sqlite_schema WHERE type = 'view'");
    EXPECT_TRUE(s.ok());
    while (*s->Step()) out.insert({s->Text(0), s->Text(1)});
    return out;
  };
  const auto new_views = views_of(archive_->db());
  for (const std::string& sql :
       {std::string(kSchema4MeasurementViews), std::string("DROP VIEW axis_results"),
        std::string("DROP VIEW run_archive"),
        std::string("CREATE VIEW axis_results AS SELECT 1 AS schema_four"),
        std::string("CREATE VIEW run_archive AS SELECT 1 AS schema_four"),
        // what schema 6 added
        std::string("DROP VIEW lot_overview"), std::string("DROP VIEW final_runs"),
        std::string("DROP VIEW retest_reasons"),
        std::string("CREATE VIEW lot_overview AS SELECT 1 AS schema_four"),
        std::string("ALTER TABLE measurements DROP COLUMN qualifier"),
        std::string("ALTER TABLE measurements DROP COLUMN uncertainty_method"),
        std::string("ALTER TABLE measurements DROP COLUMN decision_rule"),
        std::string("ALTER TABLE measurements DROP COLUMN guard_band"),
        std::string("ALTER TABLE curve_points DROP COLUMN alpha"),
        std::string("ALTER TABLE curve_points DROP COLUMN alpha_from"),
        // what schema 7 added
        std::string("DROP TABLE archive_chain"), std::string("DROP INDEX raw_chunks_digests"),
        std::string("ALTER TABLE raw_chunks DROP COLUMN digest"),
        std::string("ALTER TABLE runs DROP COLUMN bus_auth"),
        std::string("PRAGMA user_version = 4")}) {
    ASSERT_TRUE(archive_->db().Exec(sql).ok()) << sql;
  }
  // (schema 4 grouped by serial, every run counted: a row per unit, n = 2 + 1)
  EXPECT_EQ(Real("SELECT COUNT(*) FROM lot_statistics"), 2);
  EXPECT_EQ(Real("SELECT SUM(n) FROM lot_statistics"), 3);
  archive_.reset();

  // WHEN it is opened for writing (migrated)
  auto a = Archive::Open(path_, Archive::Mode::kWrite);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  archive_ = std::move(*a);

  // THEN it is at the current schema with a new archive's views, and the
  // statistics are over U1's retest and U2
  EXPECT_EQ(*archive_->db().QueryInt("PRAGMA user_version"), SchemaVersion());
  EXPECT_EQ(views_of(archive_->db()), new_views);
  EXPECT_EQ(Real("SELECT COUNT(*) FROM lot_statistics"), 1);
  EXPECT_EQ(Real("SELECT n FROM lot_statistics"), 2);
  EXPECT_EQ(Real("SELECT mean FROM lot_statistics"), 3);
  EXPECT_EQ(Real("SELECT pass_rate FROM lot_statistics"), 1);
}

// An archive written by schema 5 (store/testdata/schema5_archive.sql: two
// units of imuqual-history-gen, their checksums as schema 5 computed them)
// migrates to schema 6: the CHECKs take the new outcomes, the measurements
// gain their columns, the views hold the same values, and every checksum
// computed by schema 5 still verifies.
TEST_F(ViewsTest, MigrationFromSchema5KeepsDataAndChecksums) {
  // GIVEN the schema 5 archive, loaded by the SQL its dump holds
  archive_.reset();
  fs::remove(path_);
  auto dump = ReadFileToString(std::string(IMUQUAL_SOURCE_DIR) +
                               "/store/testdata/schema5_archive.sql");
  ASSERT_TRUE(dump.ok()) << dump.status().ToString();
  {
    auto db = Db::Open(path_, Db::Mode::kReadWrite);
    ASSERT_TRUE(db.ok()) << db.status().ToString();
    ASSERT_TRUE((*db)->Exec(*dump).ok());
    EXPECT_EQ(*(*db)->QueryInt("PRAGMA user_version"), 5);
    // schema 5 refuses the new verdicts
    EXPECT_FALSE((*db)->Exec("UPDATE runs SET verdict = 'INCONCLUSIVE'").ok());
  }
  int64_t values_before = 0;
  double sum_before = 0;
  {
    auto db = Db::Open(path_, Db::Mode::kReadWrite);
    ASSERT_TRUE(db.ok());
    values_before = *(*db)->QueryInt("SELECT COUNT(*) FROM lot_measurements");
    auto s = (*db)->Prepare("SELECT TOTAL(value) FROM lot_measurements WHERE value < 1e300");
    ASSERT_TRUE(s.ok() && *s->Step());
    sum_before = s->Real(0);
  }
  ASSERT_GT(values_before, 0);

  // WHEN it is opened for writing (migrated)
  auto a = Archive::Open(path_, Archive::Mode::kWrite);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  archive_ = std::move(*a);

  // THEN it is at schema 6, intact, and schema 5's checksums all verify
  EXPECT_EQ(*archive_->db().QueryInt("PRAGMA user_version"), SchemaVersion());
  EXPECT_EQ(SchemaVersion(), 7);
  std::vector<std::string> problems;
  auto checked = CheckChecksums(archive_->db(), -1,
                                [&](const std::string& p) { problems.push_back(p); });
  ASSERT_TRUE(checked.ok()) << checked.status().ToString();
  EXPECT_EQ(*checked, 0);
  EXPECT_TRUE(problems.empty()) << problems.front();
  auto integrity = CheckIntegrity(archive_->db(), [&](const std::string& p) { problems.push_back(p); });
  EXPECT_EQ(*integrity, 0);
  EXPECT_EQ(*archive_->db().QueryInt("SELECT COUNT(*) FROM runs WHERE results_crc32c IS NULL"), 0);
  // AND the views hold the same values, the new columns NULL
  EXPECT_EQ(*archive_->db().QueryInt("SELECT COUNT(*) FROM lot_measurements"), values_before);
  EXPECT_EQ(Real("SELECT TOTAL(value) FROM lot_measurements WHERE value < 1e300"), sum_before);
  EXPECT_EQ(*archive_->db().QueryInt(
                "SELECT COUNT(*) FROM lot_measurements WHERE qualifier IS NOT NULL OR "
                "uncertainty_method IS NOT NULL OR decision_rule IS NOT NULL OR guard_band IS NOT NULL"),
            0);
  // AND the wider CHECKs take the new outcomes (in this connection: the
  // schema it reads is the rewritten one) and still refuse others
  auto key = archive_->FindRunKey("S5-L001-U001-R1");
  ASSERT_TRUE(key.ok() && key->has_value());
  auto result = archive_->LoadResult(**key);
  ASSERT_TRUE(result.ok() && result->has_value());
  ResultRecord r = **result;
  r.verdict = "INCONCLUSIVE";
  ASSERT_FALSE(r.measurements.empty());
  pb::Measurement& m = r.measurements.front();
  m.set_outcome(pb::INCONCLUSIVE);
  m.set_qualifier(pb::UPPER_BOUND);
  m.set_uncertainty_method("test: a stated sigma");
  m.set_decision_rule(pb::Limit::GUARDED_ACCEPTANCE);
  m.set_guard_band(0.25);
  ASSERT_TRUE(archive_->PutResult(**key, r).ok());
  for (const char* verdict : {"ABORTED", "ERROR", "PASS"}) {
    r.verdict = verdict;
    EXPECT_TRUE(archive_->PutResult(**key, r).ok()) << verdict;
  }
  EXPECT_FALSE(archive_->db().Exec("UPDATE runs SET verdict = 'MAYBE'").ok());
  EXPECT_FALSE(archive_->db().Exec("UPDATE measurements SET outcome = 'ABORTED'").ok());
  EXPECT_FALSE(archive_->db().Exec("UPDATE measurements SET qualifier = 'UPPER_BOUND'").ok());
  auto reread = archive_->LoadResult(**key);
  ASSERT_TRUE(reread.ok() && reread->has_value());
  const pb::Measurement& back = (*reread)->measurements.front();
  EXPECT_EQ(back.outcome(), pb::INCONCLUSIVE);
  EXPECT_EQ(back.qualifier(), pb::UPPER_BOUND);
  EXPECT_EQ(back.uncertainty_method(), "test: a stated sigma");
  EXPECT_EQ(back.decision_rule(), pb::Limit::GUARDED_ACCEPTANCE);
  EXPECT_EQ(back.guard_band(), 0.25);
  // AND the marks enter the checksum: the sealed run verifies, and a
  // changed mark does not
  problems.clear();
  EXPECT_EQ(*CheckChecksums(archive_->db(), **key, [&](const std::string& p) { problems.push_back(p); }), 0);
  ASSERT_TRUE(archive_->db().Exec("UPDATE measurements SET guard_band = 0.5 WHERE guard_band = 0.25").ok());
  EXPECT_EQ(*CheckChecksums(archive_->db(), **key, [&](const std::string& p) { problems.push_back(p); }), 1);
}

}  // namespace
}  // namespace imuqual::store
