#include "common/listening_clock.h"

#include <gtest/gtest.h>

namespace imuqual {
namespace {

TEST(ListeningClockTest, FollowsTheMonotonicClockWhileAwake) {
  ListeningClock c(1.0);
  const double t0 = c.Observe(100.0);
  for (double t = 100.0; t <= 110.0; t += 0.1) EXPECT_NEAR(c.Observe(t) - t0, t - 100.0, 1e-9);
  EXPECT_EQ(c.paused_s(), 0.0);
}

TEST(ListeningClockTest, AFreezeCountsOnlyOneStep) {
  // GIVEN a process observing every 100 ms
  ListeningClock c(1.0);
  const double t0 = c.Observe(0.0);
  c.Observe(0.1);
  // WHEN it is stopped for 60 s
  const double woke = c.Observe(60.1);
  // THEN only the allowed step passed for it, and time runs on from there.
  EXPECT_NEAR(woke - t0, 0.1 + 1.0, 1e-9);
  EXPECT_NEAR(c.paused_s(), 59.0, 1e-9);
  // A second silence of 10 s between observations: again one step.
  EXPECT_NEAR(c.Observe(70.1) - woke, 1.0, 1e-9);
  EXPECT_NEAR(c.paused_s(), 59.0 + 9.0, 1e-9);
}

TEST(ListeningClockTest, EarlierTimesFromOtherThreadsDoNotRunItBackwards) {
  ListeningClock c(1.0);
  c.Observe(5.0);
  const double a = c.Observe(5.5);
  EXPECT_EQ(c.Observe(5.2), a);  // a thread that read the clock before another
  EXPECT_GT(c.Observe(5.6), a);
}

}  // namespace
}  // namespace imuqual
