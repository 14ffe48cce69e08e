#include "station/station_config.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

namespace imuqual::station {
namespace {

const char kGood[] =
    R"pb(# bench A
         station_id: "bench-A"
         lot: "LOT-7"
         operator_name: "ana"
         plan: "builtin:tactical"
         duration_s: 7200
         archive: "data/lot7.db"
         analyze_shards: 3
         pace: 1
         slot { name: "A1" unit_serial: "SN-1" source: "sim:tactical,index=0" }
         slot { name: "A2" unit_serial: "SN-2" source: "csv:rec/sn2.csv,rate=200,counter=count" }
         slot { unit_serial: "SN-3" source: "serial:/dev/ttyUSB0,protocol=xsens,baud=921600" }
    )pb";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string ErrorOf(const std::string& text) {
  auto c = ParseStationConfig(text, "/etc/imuqual/bench-a.textproto");
  return c.ok() ? std::string("(no error)") : c.status().message();
}

TEST(StationConfigTest, GoodConfigBecomesAStationRun) {
  auto c = ParseStationConfig(kGood, "/etc/imuqual/bench-a.textproto");
  ASSERT_TRUE(c.ok()) << c.status().message();
  // Relative paths are relative to the file; absolute ones and devices stay.
  EXPECT_EQ(c->archive(), "/etc/imuqual/data/lot7.db");
  EXPECT_EQ(c->slot(1).source(), "csv:/etc/imuqual/rec/sn2.csv,rate=200,counter=count");
  EXPECT_EQ(c->slot(2).source(), "serial:/dev/ttyUSB0,protocol=xsens,baud=921600");
  EXPECT_EQ(c->slot(2).name(), "3");  // unnamed slots are numbered
  const StationRunOptions o = StationRunFromConfig(*c);
  EXPECT_EQ(o.station, "bench-A");
  EXPECT_EQ(o.lot, "LOT-7");
  EXPECT_EQ(o.operator_name, "ana");
  EXPECT_EQ(o.plan_spec, "builtin:tactical");
  EXPECT_EQ(o.duration_s, 7200);
  EXPECT_EQ(o.db_path, "/etc/imuqual/data/lot7.db");
  EXPECT_EQ(o.analyze_shards, 3);
  EXPECT_EQ(o.pace, 1);
  EXPECT_EQ(o.sim_units, 0);
  ASSERT_EQ(o.units.size(), 3u);
  EXPECT_EQ(o.units[0], "SN-1=sim:tactical,index=0");
  EXPECT_EQ(o.slots, (std::vector<std::string>{"A1", "A2", "3"}));
  EXPECT_FALSE(o.rate_hz.has_value());  // not given: each source's own rate
  EXPECT_TRUE(o.Validate().ok()) << o.Validate().message();
}

TEST(StationConfigTest, ARateIsGivenOrAbsentNeverZero) {
  const std::string file = "/etc/imuqual/bench-a.textproto";
  auto c = ParseStationConfig(Replace(kGood, "pace: 1", "pace: 1 rate_hz: 400"), file);
  ASSERT_TRUE(c.ok()) << c.status().message();
  EXPECT_EQ(StationRunFromConfig(*c).rate_hz, 400);
  for (const char* bad : {"rate_hz: 0", "rate_hz: -5", "rate_hz: nan", "rate_hz: inf"}) {
    EXPECT_EQ(ErrorOf(Replace(kGood, "pace: 1", bad)),
              file + ":9: rate_hz: must be > 0 Hz (leave it out for the profile's rate)")
        << bad;
  }
}

TEST(StationConfigTest, ErrorsNameTheFileLineAndField) {
  const std::string file = "/etc/imuqual/bench-a.textproto";
  EXPECT_EQ(ErrorOf(Replace(kGood, "duration_s: 7200", "duration_s: 0")),
            file + ":6: duration_s: must be > 0 seconds");
  EXPECT_EQ(ErrorOf(Replace(kGood, "lot: \"LOT-7\"", "lot: \"LOT 7\"")),
            file + ":3: lot 'LOT 7' must be 1-48 characters of A-Z a-z 0-9 . _ -");
  EXPECT_EQ(ErrorOf(Replace(kGood, "lot: \"LOT-7\"\n", "")),
            file + ": lot '' must be 1-48 characters of A-Z a-z 0-9 . _ -");
  EXPECT_EQ(ErrorOf(Replace(kGood, "analyze_shards: 3", "analyze_shards: 99")),
            file + ":8: analyze_shards: must be 1..64");
  EXPECT_EQ(ErrorOf(Replace(kGood, "unit_serial: \"SN-2\"", "unit_serial: \"SN-1\"")),
            file + ":11: slot 2: unit SN-1 is in two slots");
  EXPECT_EQ(ErrorOf(Replace(kGood, "slot { unit_serial: \"SN-3\"",
                            "slot { name: \"A1\" unit_serial: \"SN-3\"")),
            file + ":12: slot 3: slot name 'A1' twice");
  EXPECT_EQ(ErrorOf(Replace(kGood, "sim:tactical,index=0", "tactical"))
                .rfind(file + ":10: slot 1 source: ", 0),
            0u);
  EXPECT_EQ(ErrorOf(Replace(kGood, "pace: 1", "pace: -1")), file + ":9: pace: must be >= 0");
  EXPECT_EQ(ErrorOf(Replace(kGood, "builtin:tactical", "builtin:nope"))
                .rfind(file + ":5: plan: no built-in plan 'nope'", 0),
            0u);
  // Syntax: unknown fields and bad values, with line and column.
  EXPECT_EQ(ErrorOf(Replace(kGood, "pace: 1", "speed: 1")).rfind(file + ":9:", 0), 0u);
  EXPECT_NE(ErrorOf(Replace(kGood, "pace: 1", "speed: 1")).find("speed"), std::string::npos);
  EXPECT_EQ(ErrorOf(Replace(kGood, "duration_s: 7200", "duration_s: \"long\""))
                .substr(0, file.size() + 3),
            file + ":6:");
  const std::string no_slots = kGood;
  EXPECT_EQ(ErrorOf(no_slots.substr(0, no_slots.find("slot {"))),
            file + ": no slot: give at least one slot { ... }");
}

// A station or a plan may require an operator: a file without one is
// refused at the line that asks for it.
TEST(StationConfigTest, RequiredOperatorIsNamed) {
  const std::string file = "/etc/imuqual/bench-a.textproto";
  const std::string no_operator = Replace(kGood, "operator_name: \"ana\"\n", "");
  EXPECT_EQ(ErrorOf(no_operator), "(no error)");  // not required: fine
  EXPECT_EQ(ErrorOf(Replace(no_operator, "pace: 1", "pace: 1\nrequire_operator: true")),
            file +
                ":9: operator_name: required (require_operator is set): the operator who "
                "runs the station");
  EXPECT_EQ(ErrorOf(Replace(kGood, "pace: 1", "pace: 1\nrequire_operator: true")), "(no error)");
  // A name of blanks is no name.
  EXPECT_NE(ErrorOf(Replace(Replace(kGood, "\"ana\"", "\"  \""), "pace: 1",
                            "pace: 1\nrequire_operator: true"))
                .find("operator_name: required"),
            std::string::npos);
  // A plan that requires one.
  const std::string plan = ::testing::TempDir() + "/require-operator.textproto";
  {
    std::ofstream out(plan);
    out << "name: \"signed\" axes { name: \"gx\" kind: GYRO } nominal_rate_hz: 100 "
           "min_duration_s: 60 require_operator: true\n";
  }
  const std::string with_plan = Replace(no_operator, "builtin:tactical", plan);
  EXPECT_EQ(ErrorOf(with_plan), file +
                                    ":4: operator_name: required (plan signed has "
                                    "require_operator): the operator who runs the station");
  EXPECT_EQ(ErrorOf(Replace(kGood, "builtin:tactical", plan)), "(no error)");
}

TEST(StationConfigTest, MissingFileIsOneLine) {
  auto c = LoadStationConfig("/nonexistent/station.textproto");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.status().message().find("/nonexistent/station.textproto"), std::string::npos);
  EXPECT_EQ(c.status().message().find('\n'), std::string::npos);
}

}  // namespace
}  // namespace imuqual::station
