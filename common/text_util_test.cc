// The small text helpers the CLI's conventions rest on: the closest command
// to a typo, the natural order of slots, and numbers that read back exactly.
#include "common/text_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common/strings.h"

namespace imuqual {
namespace {

TEST(TextUtilTest, ClosestNameAllowsFewEdits) {
  const std::vector<std::string> commands = {"run", "lots", "lot", "reanalyze", "report"};
  EXPECT_EQ(ClosestName("reanalyse", commands), "reanalyze");
  EXPECT_EQ(ClosestName("lotz", commands), "lots");  // ties: the first
  EXPECT_EQ(ClosestName("raport", commands), "report");
  EXPECT_EQ(ClosestName("frobnicate", commands), "");
  EXPECT_EQ(ClosestName("x", commands), "");  // one letter: no edit is fewer than half of it
  EXPECT_EQ(ClosestName("", commands), "");
}

TEST(TextUtilTest, NaturalLessOrdersSlotsAsNumbers) {
  std::vector<std::string> slots = {"10", "A10", "2", "B1", "A2", "1", "A1"};
  std::sort(slots.begin(), slots.end(), NaturalLess);
  EXPECT_EQ(slots, (std::vector<std::string>{"1", "2", "10", "A1", "A2", "A10", "B1"}));
  EXPECT_FALSE(NaturalLess("A02", "A2"));  // equal as numbers
  EXPECT_FALSE(NaturalLess("A2", "A02"));
  EXPECT_TRUE(NaturalLess("A2", "A2b"));
  EXPECT_FALSE(NaturalLess("", ""));
  EXPECT_TRUE(NaturalLess("", "1"));
}

TEST(TextUtilTest, ABlankNameIsNone) {
  EXPECT_TRUE(IsBlank(""));
  EXPECT_TRUE(IsBlank(" \t "));
  EXPECT_FALSE(IsBlank(" ana "));
}

TEST(TextUtilTest, ShortestRealReadsBackExactly) {
  EXPECT_EQ(ShortestReal(0.04), "0.04");
  EXPECT_EQ(ShortestReal(0.1 + 0.2), "0.30000000000000004");
  EXPECT_EQ(ShortestReal(-1e-300), "-1e-300");
  for (double v : {1.0 / 3, 6780.0, 2.2405248391380344, 1e22, 2.5e-308,
                   std::numeric_limits<double>::max()}) {
    EXPECT_EQ(std::stod(ShortestReal(v)), v) << ShortestReal(v);
  }
}

}  // namespace
}  // namespace imuqual
