#include "report/marks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace imuqual::report {
namespace {

// A value and its uncertainty are quoted as a measurement is (GUM 7.2.6):
// u to two significant digits, the value to u's last digit.
TEST(QuotedWithUncertaintyTest, TwoDigitsOfUAndTheValueToMatch) {
  using P = std::pair<std::string, std::string>;
  EXPECT_EQ(QuotedWithUncertainty(409.6, 283.0), (P{"410", "280"}));  // not "409.6 ± 2.8e+02"
  EXPECT_EQ(QuotedWithUncertainty(404.0, 283.0), (P{"400", "280"}));
  EXPECT_EQ(QuotedWithUncertainty(10.2, 0.81), (P{"10.20", "0.81"}));
  EXPECT_EQ(QuotedWithUncertainty(20.2449, 0.0012), (P{"20.2449", "0.0012"}));
  EXPECT_EQ(QuotedWithUncertainty(-3.14159, 0.25), (P{"-3.14", "0.25"}));
  // u far under the value (a simulated clock's rate): ten digits, not twenty.
  EXPECT_EQ(QuotedWithUncertainty(100.00000000000001, 2.4e-15), (P{"100", "2.4e-15"}));
  EXPECT_EQ(QuotedWithUncertainty(99.99999123456789, 2.4e-12), (P{"99.99999123", "2.4e-12"}));
  // u rounding up into a new decade: 0.996 is 1.0, and the value follows.
  EXPECT_EQ(QuotedWithUncertainty(5.4321, 0.996), (P{"5.4", "1.0"}));
  EXPECT_EQ(QuotedWithUncertainty(0.4, 280.0), (P{"0", "280"}));
  // Exponent form far from 1.
  EXPECT_EQ(QuotedWithUncertainty(1.2346e-6, 4.5e-8), (P{"1.235e-06", "4.5e-08"}));
  EXPECT_EQ(QuotedWithUncertainty(12345678.0, 45678.0), (P{"1.2346e+07", "4.6e+04"}));
  // No usable u: the value to its digits, u as it is.
  EXPECT_EQ(QuotedWithUncertainty(409.6, 0.0), (P{"409.6", "0"}));
  EXPECT_EQ(QuotedWithUncertainty(409.6, std::numeric_limits<double>::quiet_NaN()),
            (P{"409.6", "-"}));
}

TEST(MarkedValueTest, MarksAroundTheQuotedValue) {
  EXPECT_EQ(MarkedValue(409.6, pb::QUALIFIER_NONE, 283.0, 4, true), "410 \u00B1 280");
  EXPECT_EQ(MarkedValue(409.6, pb::QUALIFIER_NONE, 283.0, 4, false), "409.6");
  EXPECT_EQ(MarkedValue(22.13, pb::MINIMUM_NOT_RESOLVED, 1.3, 4, true), "22.1\u2020 \u00B1 1.3");
  EXPECT_EQ(MarkedValue(0.684, pb::UPPER_BOUND, 0.1, 4, true), "\u2264 0.684");
}

}  // namespace
}  // namespace imuqual::report
