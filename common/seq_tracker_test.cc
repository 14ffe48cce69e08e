#include "common/seq_tracker.h"

#include <gtest/gtest.h>

namespace imuqual {
namespace {

using Arrival = SeqTracker::Arrival;

TEST(SeqTrackerTest, InOrderDuplicatesAndAbsurd) {
  SeqTracker t;
  EXPECT_EQ(t.Offer(0), Arrival::kNew);
  EXPECT_EQ(t.Offer(1), Arrival::kNew);
  EXPECT_EQ(t.Offer(1), Arrival::kDuplicate);
  EXPECT_EQ(t.Offer(0), Arrival::kDuplicate);
  EXPECT_EQ(t.Offer(-1), Arrival::kAbsurd);
  EXPECT_EQ(t.Offer(int64_t{1} << 40), Arrival::kAbsurd);
  EXPECT_EQ(t.next_seq(), 2);
}

TEST(SeqTrackerTest, OutOfOrderFillsTheFrontier) {
  SeqTracker t;
  EXPECT_EQ(t.Offer(2), Arrival::kNew);
  EXPECT_EQ(t.Offer(1), Arrival::kNew);
  EXPECT_EQ(t.Offer(2), Arrival::kDuplicate);
  EXPECT_EQ(t.next_seq(), 0);
  EXPECT_EQ(t.ahead(), 2u);
  EXPECT_EQ(t.Offer(0), Arrival::kNew);
  EXPECT_EQ(t.next_seq(), 3);
  EXPECT_EQ(t.ahead(), 0u);
}

TEST(SeqTrackerTest, RequestsHolesAfterADelayWithBackoff) {
  // GIVEN seqs 0, 1, 4 received and the run announced up to 6.
  SeqTracker t;
  for (int s : {0, 1, 4}) t.Offer(s);
  t.SetAnnouncedLast(6);
  // WHEN asked right away THEN nothing is due (the hole may fill by itself).
  EXPECT_TRUE(t.DueRequests(10.0).empty());
  // THEN after the first delay both holes are requested once.
  auto due = t.DueRequests(10.06);
  ASSERT_EQ(due.size(), 2u);
  EXPECT_EQ(due[0], (SeqRange{2, 3}));
  EXPECT_EQ(due[1], (SeqRange{5, 6}));
  EXPECT_TRUE(t.DueRequests(10.1).empty());
  // Back-off doubled to 0.1 s.
  EXPECT_EQ(t.DueRequests(10.17).size(), 2u);
  // Part of a hole arriving is progress: the rest is asked for at once.
  t.Offer(2);
  auto next = t.DueRequests(10.2);  // before [5, 6] is due again (10.37)
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0], (SeqRange{3, 3}));
  t.Offer(3);
  t.Offer(5);
  t.Offer(6);
  EXPECT_EQ(t.next_seq(), 7);
  EXPECT_TRUE(t.DueRequests(100).empty());
}

TEST(SeqTrackerTest, GivesUpInOrderAndCompletes) {
  SeqTracker::Options opt;
  opt.give_up_after_s = 5;
  SeqTracker t(0, opt);
  for (int s : {0, 3}) t.Offer(s);
  t.SetAnnouncedLast(5);
  t.SetFinal();
  EXPECT_FALSE(t.complete());
  EXPECT_TRUE(t.TakeGivenUp(0.0).empty());  // first seen now
  EXPECT_TRUE(t.TakeGivenUp(4.9).empty());
  auto lost = t.TakeGivenUp(5.0);
  ASSERT_EQ(lost.size(), 2u);
  EXPECT_EQ(lost[0], (SeqRange{1, 2}));
  EXPECT_EQ(lost[1], (SeqRange{4, 5}));
  EXPECT_EQ(t.next_seq(), 6);
  EXPECT_TRUE(t.complete());
}

TEST(SeqTrackerTest, PostponedHolesAreNeitherRequestedNorGivenUp) {
  // GIVEN a hole seen at t = 0 with a 5 s give-up
  SeqTracker::Options opt;
  opt.give_up_after_s = 5;
  SeqTracker t(0, opt);
  t.Offer(0);
  t.SetAnnouncedLast(3);
  EXPECT_TRUE(t.TakeGivenUp(0.0).empty());
  // WHEN the receiver cannot write for 8 s (it postpones every tick)
  for (double now = 0; now <= 8.0; now += 0.5) t.Postpone(now);
  // THEN the hole is neither due nor given up right after, and gets its full
  // give-up time from the last postponement
  EXPECT_TRUE(t.DueRequests(8.0).empty());
  EXPECT_TRUE(t.TakeGivenUp(12.9).empty());
  EXPECT_EQ(t.next_seq(), 1);
  auto lost = t.TakeGivenUp(13.0);
  ASSERT_EQ(lost.size(), 1u);
  EXPECT_EQ(lost[0], (SeqRange{1, 3}));
}

TEST(SeqTrackerTest, LongHolesAreRequestedInBoundedSlicesAndProgressResetsTheClock) {
  // GIVEN a consumer that restarted: the run is at seq 10000, nothing held.
  SeqTracker::Options opt;
  opt.max_request = 100;
  opt.give_up_after_s = 5;
  SeqTracker t(0, opt);
  t.SetAnnouncedLast(9999);
  // WHEN it catches up slice by slice, each slice taking 2 s to arrive
  double now = 0;
  t.DueRequests(now);
  now = opt.first_request_delay_s;
  for (int64_t first = 0; first < 10000; first += 100) {
    auto due = t.DueRequests(now);
    ASSERT_EQ(due.size(), 1u) << first;
    EXPECT_EQ(due[0], (SeqRange{first, first + 99}));
    now += 2.0;  // 100 slices x 2 s = 200 s, far beyond give_up_after_s
    for (int64_t s = first; s <= first + 99; ++s) t.Offer(s);
    // THEN progress keeps the hole alive: nothing is given up.
    EXPECT_TRUE(t.TakeGivenUp(now).empty()) << first;
  }
  EXPECT_EQ(t.next_seq(), 10000);
}

}  // namespace
}  // namespace imuqual
