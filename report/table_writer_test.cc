#include "report/table_writer.h"

#include <gtest/gtest.h>

#include <cmath>

namespace imuqual::report {
namespace {

TableWriter Sample() {
  TableWriter t({"name", "value", "count"});
  t.AddRow({Cell::Text("a,b"), Cell::Real(0.1), Cell::Int(3)});
  t.AddRow({Cell::Text("say \"hi\""), Cell::Real(std::nan("")), Cell::Int(-1)});
  return t;
}

TEST(TableWriterTest, CsvQuotesAndKeepsFullPrecision) {
  EXPECT_EQ(Sample().Render(Format::kCsv),
            "name,value,count\n\"a,b\",0.1,3\n\"say \"\"hi\"\"\",,-1\n");
}

// A number shown rounded (to its uncertainty) in the table and HTML, exact
// in CSV, JSON and the HTML cell's data-v.
TEST(TableWriterTest, ARealShownRoundedIsExactInData) {
  TableWriter t({"v"});
  t.AddRow({Cell::RealShown(409.637, "410")});
  EXPECT_NE(t.Render(Format::kTable).find("410"), std::string::npos);
  EXPECT_EQ(t.Render(Format::kTable).find("409"), std::string::npos);
  EXPECT_EQ(t.Render(Format::kCsv), "v\n409.637\n");
  EXPECT_NE(t.Render(Format::kJson).find("409.637"), std::string::npos);
  const std::string html = t.Render(Format::kHtml);
  EXPECT_NE(html.find("data-v=\"409.637\">410</td>"), std::string::npos) << html;
}

// A table for a narrow screen leaves whole columns out, in the order given,
// and takes back the most important one that fits again; the cells kept are
// the wide table's, never cut.
TEST(TableWriterTest, ANarrowTableLeavesWholeColumnsOut) {
  TableWriter t({"serial", "value", "wide_counts_column", "verdict"});
  t.AddRow({Cell::Text("U1"), Cell::Real(30.25), Cell::Int(0), Cell::Text("FAIL")});
  t.AddRow({Cell::Text("U22"), Cell::Real(11.5), Cell::Int(7), Cell::Text("PASS")});
  std::vector<std::string> left_out;
  const std::string wide = t.RenderTableWithin(1000, {"wide_counts_column", "value"}, &left_out);
  EXPECT_EQ(wide, t.Render(Format::kTable));
  EXPECT_TRUE(left_out.empty());
  // 30 columns: the counts go; "value" (dropped only if needed) stays.
  const std::string narrow = t.RenderTableWithin(30, {"wide_counts_column", "value"}, &left_out);
  EXPECT_EQ(left_out, (std::vector<std::string>{"wide_counts_column"}));
  EXPECT_NE(narrow.find("30.25"), std::string::npos) << narrow;
  for (size_t from = 0, end; from < narrow.size(); from = end + 1) {
    end = narrow.find('\n', from);
    EXPECT_LE(end - from, 30u) << narrow;
  }
  // Dropped "value" first, then the counts: the counts' room lets "value" back.
  const std::string back = t.RenderTableWithin(30, {"value", "wide_counts_column"}, &left_out);
  EXPECT_EQ(left_out, (std::vector<std::string>{"wide_counts_column"}));
  EXPECT_EQ(back, narrow);
}

TEST(TableWriterTest, JsonHasNullForNaN) {
  EXPECT_EQ(Sample().Render(Format::kJson),
            "[\n {\"name\": \"a,b\", \"value\": 0.1, \"count\": 3},\n"
            " {\"name\": \"say \\\"hi\\\"\", \"value\": null, \"count\": -1}\n]\n");
  EXPECT_EQ(TableWriter({"x"}).Render(Format::kJson), "[]\n");
}

TEST(TableWriterTest, TableAlignsNumbersRight) {
  EXPECT_EQ(Sample().Render(Format::kTable),
            "name      value  count\n"
            "--------  -----  -----\n"
            "a,b         0.1      3\n"
            "say \"hi\"      -     -1\n");
}

// A yes/no fact is a JSON boolean, true/false in CSV, yes/no for people.
TEST(TableWriterTest, BooleansAreBooleans) {
  TableWriter t({"name", "differs"});
  t.AddRow({Cell::Text("a"), Cell::Bool(true)});
  t.AddRow({Cell::Text("b"), Cell::Bool(false)});
  EXPECT_EQ(
      t.Render(Format::kJson),
      "[\n {\"name\": \"a\", \"differs\": true},\n {\"name\": \"b\", \"differs\": false}\n]\n");
  EXPECT_EQ(t.Render(Format::kCsv), "name,differs\na,true\nb,false\n");
  EXPECT_EQ(t.Render(Format::kTable), "name  differs\n----  -------\na     yes\nb     no\n");
}

// Marked values ("≤ 0.68", "22.1† ± 1.3") align right by the columns they
// take, not their bytes.
TEST(TableWriterTest, MarkedNumbersAlignByTheirColumns) {
  TableWriter t({"v"});
  t.AddRow({Cell::NumText("\u2264 0.68")});
  t.AddRow({Cell::NumText("22.1\u2020 \u00B1 1.3")});
  t.AddRow({Cell::NumText("n/m")});
  EXPECT_EQ(t.Render(Format::kTable),
            "v\n"
            "-----------\n"
            "     \u2264 0.68\n"
            "22.1\u2020 \u00B1 1.3\n"
            "        n/m\n");
  EXPECT_EQ(t.Render(Format::kCsv), "v\n\u2264 0.68\n22.1\u2020 \u00B1 1.3\nn/m\n");
  EXPECT_EQ(DisplayWidth("\u2264 0.68"), 6u);
}

TEST(TableWriterTest, ParseFormat) {
  EXPECT_TRUE(ParseFormat("csv").ok());
  EXPECT_FALSE(ParseFormat("xml").ok());
}

}  // namespace
}  // namespace imuqual::report
