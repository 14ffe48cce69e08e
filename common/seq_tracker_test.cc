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
  auto due = t.DueRequests(10.31);
  ASSERT_EQ(due.size(), 2u);
  EXPECT_EQ(due[0], (SeqRange{2, 3}));
  EXPECT_EQ(due[1], (SeqRange{5, 6}));
  EXPECT_TRUE(t.DueRequests(10.5).empty());
  // Back-off doubled to 0.6 s.
  EXPECT_EQ(t.DueRequests(10.92).size(), 2u);
  // Part of a hole arriving keeps the rest scheduled, not restarted.
  t.Offer(2);
  EXPECT_TRUE(t.DueRequests(11.0).empty());
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

}  // namespace
}  // namespace imuqual
