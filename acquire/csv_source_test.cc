// CsvSource and the csv:/sim: source specs: a file without samples is refused
// at open (never a complete run of 0 samples), the first row still goes
// through the counter checks, and a rate= that is no rate is refused.
#include "acquire/csv_source.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "acquire/source_spec.h"
#include "tests/test_util.h"

namespace imuqual::acquire {
namespace {

using testing::TempDir;

CsvSourceOptions Options(const std::string& path) {
  CsvSourceOptions o;
  o.path = path;
  o.rate_hz = 100;
  for (const char* name : {"gx", "gy"}) {
    pb::Axis a;
    a.set_name(name);
    a.set_kind(pb::GYRO);
    o.axes.push_back(a);
  }
  return o;
}

std::string Write(const TempDir& dir, const std::string& name, const std::string& text) {
  const std::string path = dir.path(name);
  std::ofstream(path) << text;
  return path;
}

TEST(CsvSourceTest, AHeaderWithoutRowsIsRefusedAsAnEmptyFileIs) {
  TempDir dir("csv_source_empty");
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"empty.csv", ""},
           {"header.csv", "gx,gy\n"},
           {"commented.csv", "# unit 7\ngx,gy\n\n# end\n"}}) {
    const std::string path = Write(dir, name, text);
    auto source = CsvSource::Open(Options(path));
    ASSERT_FALSE(source.ok()) << name;
    EXPECT_NE(source.status().message().find(path), std::string::npos) << source.status().message();
    EXPECT_NE(source.status().message().find("no samples"), std::string::npos)
        << source.status().message();
    EXPECT_EQ(source.status().message().find('\n'), std::string::npos) << source.status().message();
  }
}

TEST(CsvSourceTest, TheFirstRowReadAtOpenIsDeliveredOnce) {
  TempDir dir("csv_source_rows");
  // GIVEN a file with a header and three rows
  const std::string path = Write(dir, "rows.csv", "gx,gy\n1,2\n3,4\n5,6\n");
  auto source = CsvSource::Open(Options(path));
  ASSERT_TRUE(source.ok()) << source.status().message();
  // (its planned length, for progress: three rows at 100 Hz)
  EXPECT_DOUBLE_EQ((*source)->info().planned_s, 0.03);
  // WHEN it is read two samples at a time
  SampleBlock block;
  auto n = (*source)->Read(2, &block);
  // THEN every row comes once, in order, then the end
  ASSERT_TRUE(n.ok());
  ASSERT_EQ(*n, 2);
  EXPECT_EQ(block.first_sample, 0);
  EXPECT_EQ(block.samples[0], (std::vector<float>{1, 3}));
  EXPECT_EQ(block.samples[1], (std::vector<float>{2, 4}));
  n = (*source)->Read(2, &block);
  ASSERT_TRUE(n.ok());
  ASSERT_EQ(*n, 1);
  EXPECT_EQ(block.first_sample, 2);
  EXPECT_EQ(block.samples[0], (std::vector<float>{5}));
  n = (*source)->Read(2, &block);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 0);
}

// A temperature column (deg C): each block carries the mean of its rows'
// values, an empty cell being none; the column is not an axis.
TEST(CsvSourceTest, ATemperatureColumnGivesEachBlockItsMeanTemperature) {
  TempDir dir("csv_source_temperature");
  const std::string path = Write(dir, "temp.csv", "gx,temp_c,gy\n1,25.0,2\n3,25.5,4\n5,,6\n7,,8\n");
  CsvSourceOptions o = Options(path);
  o.temperature_column = "temp_c";
  auto source = CsvSource::Open(o);
  ASSERT_TRUE(source.ok()) << source.status().message();
  SampleBlock block;
  auto n = (*source)->Read(3, &block);
  ASSERT_TRUE(n.ok());
  ASSERT_EQ(*n, 3);
  EXPECT_EQ(block.samples[1], (std::vector<float>{2, 4, 6}));
  ASSERT_TRUE(block.temperature_c.has_value());
  EXPECT_FLOAT_EQ(*block.temperature_c, 25.25f);  // the third row has none
  n = (*source)->Read(3, &block);
  ASSERT_TRUE(n.ok());
  ASSERT_EQ(*n, 1);
  EXPECT_FALSE(block.temperature_c.has_value());
  // Through a source spec, and a column the file does not have is named.
  SourceDefaults d;
  for (const pb::Axis& a : Options(path).axes) *d.plan.add_axes() = a;
  d.plan.set_nominal_rate_hz(100);
  EXPECT_TRUE(MakeSource(*ParseSourceSpec("csv:" + path + ",temperature=temp_c"), d).ok());
  auto missing = MakeSource(*ParseSourceSpec("csv:" + path + ",temperature=celsius"), d);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("celsius"), std::string::npos)
      << missing.status().message();
}

TEST(CsvSourceTest, TheFirstRowsCounterIsCheckedAndNamesItsLine) {
  TempDir dir("csv_source_counter");
  const std::string path = Write(dir, "counter.csv", "n,gx,gy\n-3,1,2\n");
  CsvSourceOptions o = Options(path);
  o.counter_column = std::string("n");  // (a literal assigned trips GCC 12 -Wrestrict)
  auto source = CsvSource::Open(o);
  ASSERT_TRUE(source.ok()) << source.status().message();
  SampleBlock block;
  auto n = (*source)->Read(10, &block);
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.status().message().find(path + ":2: counter 'n'"), std::string::npos)
      << n.status().message();
}

TEST(SourceSpecTest, ARateThatIsNoRateIsRefused) {
  TempDir dir("source_spec_rate");
  const std::string csv = Write(dir, "rows.csv", "gx,gy\n1,2\n");
  SourceDefaults defaults;
  defaults.lot = "L";
  defaults.duration_s = 10;
  for (const std::string& text : std::vector<std::string>{
           "sim:vg700,rate=0", "sim:vg700,rate=-5", "sim:vg700,rate=nan", "sim:vg700,rate=inf",
           "csv:" + csv + ",rate=0,axes=gx/gy", "csv:" + csv + ",rate=-1,axes=gx/gy"}) {
    auto spec = ParseSourceSpec(text);
    ASSERT_TRUE(spec.ok()) << text;
    auto source = MakeSource(*spec, defaults);
    ASSERT_FALSE(source.ok()) << text;
    EXPECT_NE(source.status().message().find("rate"), std::string::npos)
        << source.status().message();
  }
  // Without rate= a simulated unit runs at its profile's rate.
  auto spec = ParseSourceSpec("sim:vg700");
  ASSERT_TRUE(spec.ok());
  auto source = MakeSource(*spec, defaults);
  ASSERT_TRUE(source.ok()) << source.status().message();
  EXPECT_GT((*source)->info().nominal_rate_hz, 0);
}

// A recording with gyros in rad/s and accelerometers in g, columns named
// otherwise than the plan's axes, and a raw counts column with its LSB.
TEST(SourceSpecTest, EachAxisFromItsColumnInItsUnit) {
  TempDir dir("source_spec_map");
  const std::string csv =
      Write(dir, "imu.csv", "t,wx,wy,fx,counts\n0,0.5,-1,1,2000\n0.01,0.25,2,-0.5,-4000\n");
  SourceDefaults defaults;
  auto spec = ParseSourceSpec("csv:" + csv +
                              ",rate=100,axes=gx:gyro/gy:gyro/ax:accel/az:accel,gx=wx:rad/s,"
                              "gy=wy:deg/h,ax=fx:g,az=counts:mg:0.5");
  ASSERT_TRUE(spec.ok()) << spec.status().message();
  auto source = MakeSource(*spec, defaults);
  ASSERT_TRUE(source.ok()) << source.status().message();
  SampleBlock block;
  auto n = (*source)->Read(10, &block);
  ASSERT_TRUE(n.ok()) << n.status().message();
  ASSERT_EQ(*n, 2);
  // THEN each axis is in deg/s or m/s^2, as every source delivers (float32).
  const double deg = 180 / M_PI;
  EXPECT_FLOAT_EQ(block.samples[0][0], static_cast<float>(0.5 * deg));
  EXPECT_FLOAT_EQ(block.samples[0][1], static_cast<float>(0.25 * deg));
  EXPECT_FLOAT_EQ(block.samples[1][1], static_cast<float>(2.0 / 3600));
  EXPECT_FLOAT_EQ(block.samples[2][0], static_cast<float>(9.80665));
  EXPECT_FLOAT_EQ(block.samples[3][1], static_cast<float>(-4000 * 0.5 * 9.80665e-3));
  // A column alone keeps scale=.
  auto scaled = ParseSourceSpec("csv:" + csv + ",rate=100,axes=gx:gyro,gx=wx,scale=2");
  ASSERT_TRUE(scaled.ok());
  auto scaled_source = MakeSource(*scaled, defaults);
  ASSERT_TRUE(scaled_source.ok()) << scaled_source.status().message();
  auto scaled_read = (*scaled_source)->Read(10, &block);
  ASSERT_TRUE(scaled_read.ok()) << scaled_read.status().message();
  ASSERT_EQ(*scaled_read, 2);
  EXPECT_FLOAT_EQ(block.samples[0][0], 1.0f);
  // A unit of the wrong kind, an unknown one, a bad scale and an option that
  // is neither an option nor an axis are refused, each naming what is wrong.
  for (const auto& [mapping, says] : std::vector<std::pair<std::string, std::string>>{
           {"gx=wx:g", "unit 'g' is not a unit for a gyro axis (deg/s, rad/s"},
           {"ax=fx:furlong", "unit 'furlong' is not a unit for an accelerometer axis"},
           {"az=counts:mg:zero", "scale 'zero' must be a finite, non-zero number"},
           {"gq=wx", "unknown option 'gq'"}}) {
    auto bad = ParseSourceSpec("csv:" + csv + ",rate=100,axes=gx:gyro/gy:gyro/ax:accel/az:accel," +
                               mapping);
    ASSERT_TRUE(bad.ok()) << mapping;
    auto refused = MakeSource(*bad, defaults);
    ASSERT_FALSE(refused.ok()) << mapping;
    EXPECT_NE(refused.status().message().find(says), std::string::npos)
        << refused.status().message();
  }
}

}  // namespace
}  // namespace imuqual::acquire

namespace imuqual::acquire {
namespace {

// Every example of the --help text's source list is a source spec that
// parses (a help example that is refused teaches the wrong thing).
TEST(SourceSpecTest, EveryHelpExampleParses) {
  const std::string help = kSourceSpecHelp;
  int examples = 0;
  for (size_t at = help.find("e.g. --unit "); at != std::string::npos;
       at = help.find("e.g. --unit ", at + 1)) {
    const size_t begin = help.find('=', at) + 1;
    const std::string spec = help.substr(begin, help.find('\n', begin) - begin);
    const auto parsed = ParseSourceSpec(spec);
    EXPECT_TRUE(parsed.ok()) << spec << ": " << parsed.status().message();
    ++examples;
  }
  EXPECT_EQ(examples, 5);  // sim, csv, serial, archive, bag
}

}  // namespace
}  // namespace imuqual::acquire
