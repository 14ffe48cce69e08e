// The lot tools and exports on a generated history: statistics agree with
// the per-unit values they summarize, a planted difference between lots is
// found and no difference is found between a lot and itself, and every
// export reads back to what the archive holds.
#include <gtest/gtest.h>

#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>

#include <cmath>
#include <map>
#include <numbers>
#include <sstream>

#include "common/text_util.h"
#include "imuqual/record.pb.h"
#include "store/archive.h"
#include "tests/test_util.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::RunCommand;

// CSV (no quoted commas in these outputs) as header-indexed rows.
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  size_t Col(const std::string& name) const {
    const auto it = std::find(header.begin(), header.end(), name);
    EXPECT_NE(it, header.end()) << name;
    return it - header.begin();
  }
};
Csv ParseCsv(const std::string& text) {
  Csv c;
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  c.header = Split(line, ',');
  while (std::getline(in, line) && !line.empty()) c.rows.push_back(Split(line, ','));
  return c;
}

class LotToolsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir("lot_tools");
    db_ = dir_->path("history.db");
    // Two lots of 40 tactical IMUs; the second's ARW and bias instability 30 % worse.
    const auto gen = RunCommand(Bin("imuqual-history-gen") + " --db " + db_ +
                                " --lots 2 --units 40 --drift 0.3 --prefix T");
    ASSERT_EQ(gen.exit_code, 0) << gen.output;
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string Imuqual(const std::string& args) {
    const auto r = RunCommand(Bin("imuqual") + " " + args + " --db " + db_);
    EXPECT_EQ(r.exit_code, 0) << args;
    return r.output;
  }
  static testing::TempDir* dir_;
  static std::string db_;
};
testing::TempDir* LotToolsTest::dir_ = nullptr;
std::string LotToolsTest::db_;

TEST_F(LotToolsTest, StatisticsSummarizeThePerUnitValues) {
  const Csv units = ParseCsv(Imuqual("lot T-L001 --format csv"));
  const Csv stats = ParseCsv(Imuqual("lot T-L001 --stats --format csv"));
  // Recompute the gyro x bias instability statistics from the unit rows.
  std::vector<double> v;
  for (const auto& r : units.rows) {
    if (r[units.Col("axis")] != "gx") continue;
    v.push_back(std::stod(r[units.Col("bias_instability_deg_hr")]));
  }
  ASSERT_EQ(v.size(), 40u);
  double mean = 0;
  for (double x : v) mean += x / v.size();
  double ss = 0;
  for (double x : v) ss += (x - mean) * (x - mean);
  const double sd = std::sqrt(ss / (v.size() - 1));
  bool found = false;
  for (const auto& r : stats.rows) {
    if (r[stats.Col("axis")] != "gx" || r[stats.Col("measurement")] != "bias_instability") continue;
    found = true;
    // 1e-12: the same sums in a different order.
    EXPECT_NEAR(std::stod(r[stats.Col("mean")]), mean, 1e-12 * mean);
    EXPECT_NEAR(std::stod(r[stats.Col("sd")]), sd, 1e-12 * sd);
    EXPECT_EQ(r[stats.Col("n")], "40");
    EXPECT_EQ(r[stats.Col("capability_kind")], "Cpu");  // the tactical plan has a high limit only
    const double high = std::stod(r[stats.Col("high")]);
    EXPECT_NEAR(std::stod(r[stats.Col("capability")]), (high - mean) / (3 * sd), 1e-9);
  }
  EXPECT_TRUE(found);
}

TEST_F(LotToolsTest, ComparisonFindsThePlantedDriftAndNothingBetweenALotAndItself) {
  const Csv diff = ParseCsv(Imuqual("compare T-L001 T-L002 --format csv"));
  const Csv same = ParseCsv(Imuqual("compare T-L001 T-L001 --format csv"));
  int arw_rows = 0;
  for (const auto& r : diff.rows) {
    if (r[diff.Col("measurement")] != "angle_random_walk") continue;
    ++arw_rows;
    EXPECT_NE(r[diff.Col("significant")].find("mean"), std::string::npos) << r[0];
    EXPECT_GT(std::stod(r[diff.Col("mean_change")]), 0.15);  // ~30 % worse
  }
  EXPECT_EQ(arw_rows, 3);  // the three gyros
  for (const auto& r : same.rows) EXPECT_EQ(r[same.Col("significant")], "-") << r[1];
  // Bad input: an unknown lot, a bad alpha.
  EXPECT_EQ(RunCommand(Bin("imuqual") + " compare T-L001 NOPE --db " + db_ + " 2>/dev/null").exit_code, 2);
  EXPECT_EQ(RunCommand(Bin("imuqual") + " compare T-L001 T-L002 --alpha 2 --db " + db_ + " 2>/dev/null")
                .exit_code,
            2);
}

TEST_F(LotToolsTest, UnitHistoryAndRunListings) {
  const Csv unit = ParseCsv(Imuqual("unit T-L002-U007 --format csv"));
  ASSERT_EQ(unit.rows.size(), 6u);  // one run, six axes
  EXPECT_EQ(unit.rows[0][unit.Col("lot")], "T-L002");
  const Csv all = ParseCsv(Imuqual("runs --lot T-L002 --format csv"));
  EXPECT_EQ(all.rows.size(), 40u);
  const Csv failed = ParseCsv(Imuqual("runs --lot T-L002 --verdict FAIL --format csv"));
  for (const auto& r : failed.rows) EXPECT_EQ(r[failed.Col("verdict")], "FAIL");
  const Csv overview = ParseCsv(Imuqual("lots --format csv"));
  for (const auto& r : overview.rows) {
    if (r[0] == "T-L002") {
      EXPECT_EQ(std::to_string(failed.rows.size()), r[overview.Col("fail")]);
    }
  }
  EXPECT_EQ(RunCommand(Bin("imuqual") + " runs --since yesterday --db " + db_ + " 2>/dev/null").exit_code, 2);
  EXPECT_EQ(Csv(ParseCsv(Imuqual("runs --since 2999-01-01 --format csv"))).rows.size(), 0u);
}

TEST_F(LotToolsTest, JsonRecordsParseBackToTheArchivedRecords) {
  const std::string json = Imuqual("export --lot T-L001 --as json");
  pb::RunRecords records;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(json, &records).ok());
  ASSERT_EQ(records.records_size(), 40);
  auto a = store::Archive::Open(db_, store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  for (const pb::RunRecord& r : records.records()) {
    auto result = (*a)->LoadResult(**(*a)->FindRunKey(r.run_id()));
    ASSERT_TRUE(result.ok() && result->has_value());
    pb::RunRecord archived;
    ASSERT_TRUE(archived.ParseFromString((*result)->record));
    EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(r, archived)) << r.run_id();
    EXPECT_EQ(r.plan().name(), "tactical-imu-eol");
  }
}

TEST_F(LotToolsTest, KalibrYamlEqualsTheFit) {
  const std::string run = "T-L001-U003-R1";
  const std::string yaml = Imuqual("export --run " + run + " --as kalibr");
  const Csv ms = ParseCsv(Imuqual("export --run " + run + " --as measurements"));
  std::map<std::string, double> sum;
  std::map<std::string, int> count;
  for (const auto& r : ms.rows) {
    const std::string name = r[ms.Col("name")], axis = r[ms.Col("axis")];
    const double v = std::stod(r[ms.Col("value")]);
    const bool accel = !axis.empty() && axis[0] == 'a';
    // Datasheet units back to Kalibr's rad / m units.
    const double deg = std::numbers::pi / 180;
    std::string key;
    double si = 0;
    if (name == "fit_angle_random_walk") {
      key = "gyroscope_noise_density";
      si = v / 60 * deg;
    } else if (name == "fit_velocity_random_walk") {
      key = "accelerometer_noise_density";
      si = v / 60;
    } else if (name == "fit_rate_random_walk") {
      key = accel ? "accelerometer_random_walk" : "gyroscope_random_walk";
      si = accel ? v * 9.80665e-6 / 60 : v / 216000 * deg;
    } else {
      continue;
    }
    sum[key] += si;
    ++count[key];
  }
  ASSERT_EQ(count.size(), 4u);
  for (const auto& [key, total] : sum) {
    const size_t at = yaml.find("\n" + key + ": ");
    ASSERT_NE(at, std::string::npos) << key << "\n" << yaml;
    const double written = std::stod(yaml.substr(at + key.size() + 3));
    EXPECT_NEAR(written, total / count[key], 1e-12 * std::abs(written)) << key;  // same doubles
  }
  EXPECT_NE(yaml.find("update_rate: 200"), std::string::npos);
}

TEST_F(LotToolsTest, CsvExportsHaveEveryRow) {
  const Csv curves = ParseCsv(Imuqual("export --run T-L001-U001-R1 --as curves"));
  auto a = store::Archive::Open(db_, store::Archive::Mode::kRead);
  auto archived = (*a)->LoadCurves(**(*a)->FindRunKey("T-L001-U001-R1"));
  size_t points = 0;
  for (const auto& c : *archived) points += c.curve.points.size();
  EXPECT_EQ(curves.rows.size(), points);
  EXPECT_EQ(RunCommand(Bin("imuqual") + " export --lot T-L001 --as xml --db " + db_ + " 2>/dev/null").exit_code, 2);
  EXPECT_EQ(RunCommand(Bin("imuqual") + " export --as json --db " + db_ + " 2>/dev/null").exit_code, 2);
}

}  // namespace
}  // namespace imuqual
