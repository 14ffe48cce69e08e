#include "common/numeric_text.h"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

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

TEST(NumericTextTest, BinaryAndCompressedFilesGetAOneLineError) {
  // An xz file (as published recordings often are), a gzip file and other
  // binary data: named as such, on one line, no raw bytes echoed.
  const std::string xz = std::string("\xFD" "7zXZ\0\0\x04\xE6\xD6\xB4\x46", 12) + "\n1\n";
  auto a = ParseSeries(xz, "rec.csv.xz", "gx");
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.status().message(), "rec.csv.xz:1: an xz-compressed file (decompress it first)");
  auto b = ParseSeries(std::string("\x1F\x8B\x08\0abc\n1\n", 9), "r.gz");
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.status().message(), "r.gz:1: a gzip-compressed file (decompress it first)");
  auto c = ParseSeries(std::string("gx,gy\x01\n1,2\n"), "b.csv");
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().message(), "b.csv:1: not text: byte 0x01 at column 6 (a binary file?)");
  auto d = ParseSeries(std::string("gx\n1\n2\x02x\n"), "d.csv", "gx");
  ASSERT_FALSE(d.ok());
  EXPECT_EQ(d.status().message(), "d.csv:3: '2\\x02x' is not a number (column 'gx')");
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

// A reader told so reads a word in a measured column as NaN, counts it and
// warns once per column; a bad cell elsewhere still fails the row.
TEST(NumericTextTest, NonNumbersInMeasuredColumnsAreInvalidSamples) {
  const std::vector<std::string> lines = {"gx,gy,n", "1,2,0", "x,3,1", "4,?,2", "y,5,3", "6,7,z"};
  size_t next = 0;
  NumericRowReader reader(
      [&]() -> std::optional<std::string> {
        if (next >= lines.size()) return std::nullopt;
        return lines[next++];
      },
      "r.csv", {"gx", "gy", "n"});
  reader.ReadNonNumbersAsInvalid(2);
  ASSERT_TRUE(reader.Start().ok());
  std::vector<double> row;
  std::vector<std::vector<double>> rows;
  for (int i = 0; i < 4; ++i) {
    auto more = reader.Next(&row);
    ASSERT_TRUE(more.ok()) << more.status().message();
    ASSERT_TRUE(*more);
    rows.push_back(row);
  }
  EXPECT_EQ(rows[0], (std::vector<double>{1, 2, 0}));
  EXPECT_TRUE(std::isnan(rows[1][0]));
  EXPECT_EQ(rows[1][1], 3);
  EXPECT_TRUE(std::isnan(rows[2][1]));
  EXPECT_TRUE(std::isnan(rows[3][0]));
  EXPECT_EQ(reader.invalid_cells(), 3);
  EXPECT_EQ(reader.TakeWarnings(),
            (std::vector<std::string>{
                "r.csv:3: 'x' is not a number (column 'gx'): read as an invalid sample of that "
                "axis, as nan or an empty cell is (the first here; each is counted)",
                "r.csv:4: '?' is not a number (column 'gy'): read as an invalid sample of that "
                "axis, as nan or an empty cell is (the first here; each is counted)"}));
  EXPECT_TRUE(reader.TakeWarnings().empty());
  auto bad = reader.Next(&row);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().message(), "r.csv:6: 'z' is not a number (column 'n')");
}

// `imuqual analyze`'s reading: a word in the chosen column is an invalid
// sample (NaN), the first named; the other columns are not read at all.
TEST(NumericTextTest, ASeriesCanReadWordsAsInvalidSamples) {
  std::vector<std::string> warnings;
  auto v = ParseSeries("t,gx\n0,1\n1,abc\nx,2\n2,--\n", "f.csv", "gx", &warnings);
  ASSERT_TRUE(v.ok()) << v.status().message();
  ASSERT_EQ(v->size(), 4u);
  EXPECT_TRUE(std::isnan((*v)[1]));
  EXPECT_TRUE(std::isnan((*v)[3]));
  EXPECT_EQ((*v)[2], 2);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].rfind("f.csv:3: 'abc' is not a number (column 'gx')", 0), 0u)
      << warnings[0];
  // Without the request a word is still the error it was.
  EXPECT_FALSE(ParseSeries("t,gx\n0,1\n1,abc\n", "f.csv", "gx").ok());
  // A short row is not a bad cell: still an error.
  EXPECT_FALSE(ParseSeries("t,gx\n0,1\n1\n", "f.csv", "gx", &warnings).ok());
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
