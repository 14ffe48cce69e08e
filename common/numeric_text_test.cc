#include "common/numeric_text.h"

#include <gtest/gtest.h>

#include <cmath>

namespace imuqual {
namespace {

TEST(NumericTextTest, OneValuePerLineWithCommentsAndGaps) {
  auto v = ParseSeries("# header comment\n1.5\n\n  -2e-3 \nnan\n% more\n0\n", "f.txt");
  ASSERT_TRUE(v.ok()) << v.status().ToString();
  ASSERT_EQ(v->size(), 4u);
  EXPECT_EQ((*v)[0], 1.5);
  EXPECT_EQ((*v)[1], -2e-3);
  EXPECT_TRUE(std::isnan((*v)[2]));
  EXPECT_EQ((*v)[3], 0.0);  // 0 is a value, not a gap
}

TEST(NumericTextTest, CsvColumnsByName) {
  const char* csv = "time,gx,\"gy\"\n0.00,1,2\n0.01,,4\n0.02,5,6\r\n";
  auto t = ParseNumericText(csv, "f.csv", {"gy", "gx"});
  ASSERT_TRUE(t.ok()) << t.status().ToString();
  EXPECT_EQ(t->names, (std::vector<std::string>{"gy", "gx"}));
  EXPECT_EQ(t->columns[0], (std::vector<double>{2, 4, 6}));
  EXPECT_TRUE(std::isnan(t->columns[1][1]));
  auto one = ParseSeries(csv, "f.csv", "gx");
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->size(), 3u);
}

TEST(NumericTextTest, ErrorsNameLineAndColumn) {
  auto bad = ParseSeries("1\n2\nabc\n", "f.txt");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().message(), "f.txt:3: 'abc' is not a number (column 'value')");
  auto missing = ParseSeries("a,b\n1,2\n", "f.csv", "c");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().message(), "f.csv:1: no column 'c' (columns: a, b)");
  auto ambiguous = ParseSeries("a,b\n1,2\n", "f.csv");
  ASSERT_FALSE(ambiguous.ok());
  EXPECT_NE(ambiguous.status().message().find("--column"), std::string::npos);
  auto short_row = ParseSeries("a,b\n1,2\n3\n", "f.csv", "b");
  ASSERT_FALSE(short_row.ok());
  EXPECT_EQ(short_row.status().message().rfind("f.csv:3: 1 fields", 0), 0u);
  EXPECT_FALSE(ParseSeries("", "e").ok());
  EXPECT_FALSE(ParseSeries("# only a comment\n", "e").ok());
  EXPECT_FALSE(ParseSeries("a\n\"unterminated\n", "e").ok());
  EXPECT_FALSE(ParseSeries("1e999\n", "e").ok());  // out of range is not silently inf
}

}  // namespace
}  // namespace imuqual
