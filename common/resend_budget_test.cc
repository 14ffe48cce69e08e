#include "common/resend_budget.h"

#include <gtest/gtest.h>

namespace imuqual {
namespace {

TEST(ResendBudgetTest, ARequesterGetsItsBurstThenItsRate) {
  ResendBudget budget(/*bytes_per_s=*/1000, /*burst_bytes=*/4000);
  int taken = 0;
  for (int i = 0; i < 100; ++i) taken += budget.Take(7, 100, /*now_s=*/10.0);
  EXPECT_EQ(taken, 40);  // the burst
  // One second later, one second's worth more.
  taken = 0;
  for (int i = 0; i < 100; ++i) taken += budget.Take(7, 100, 11.0);
  EXPECT_EQ(taken, 10);
  // Over a long flood the average is the rate, whatever the request rate.
  taken = 0;
  for (int step = 0; step < 1000; ++step) {
    for (int i = 0; i < 50; ++i) taken += budget.Take(7, 100, 11.0 + 0.01 * (step + 1));
  }
  EXPECT_NEAR(taken * 100.0 / 10.0, 1000.0, 20.0);  // bytes per second over 10 s
}

TEST(ResendBudgetTest, OneRequesterFloodingLeavesAnotherItsBudget) {
  ResendBudget budget(1000, 4000);
  while (budget.Take(1, 100, 5.0)) {
  }
  EXPECT_FALSE(budget.Take(1, 100, 5.0));
  EXPECT_TRUE(budget.Take(2, 4000, 5.0));
}

TEST(ResendBudgetTest, RequestersAreBoundedAndTheIdlestForgotten) {
  ResendBudget budget(1000, 4000, /*max_requesters=*/3);
  budget.Take(1, 4000, 1.0);
  budget.Take(2, 4000, 2.0);
  budget.Take(3, 4000, 3.0);
  budget.Take(4, 10, 4.0);  // forgets requester 1 (idle since 1.0)
  EXPECT_EQ(budget.requesters(), 3u);
  EXPECT_TRUE(budget.Take(1, 4000, 4.0));   // as new: a full burst
  EXPECT_FALSE(budget.Take(3, 4000, 4.0));  // still spent
}

}  // namespace
}  // namespace imuqual
