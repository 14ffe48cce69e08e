#include "acquire/retention.h"

#include <gtest/gtest.h>

namespace imuqual::acquire {
namespace {

constexpr int64_t kBatchBytes = 1000;

Retention Filled(int64_t batches) {
  Retention r;
  for (int64_t seq = 0; seq < batches; ++seq) {
    r.Add({seq, 0.0, std::vector<uint8_t>(kBatchBytes, 0)});
  }
  return r;
}

TEST(RetentionTest, AcknowledgedBatchesGoBeyondKeep) {
  Retention r = Filled(100);
  const Retention::Pruned p = r.Prune(/*keep=*/10, /*acknowledged=*/100, /*max_bytes=*/1 << 30);
  EXPECT_EQ(r.size(), 10u);
  EXPECT_EQ(r.first_seq(), 90);
  EXPECT_EQ(p.unacknowledged, 0);
  ASSERT_NE(r.Find(95), nullptr);
  EXPECT_EQ(r.Find(95)->seq, 95);
  EXPECT_EQ(r.Find(5), nullptr);
}

TEST(RetentionTest, UnacknowledgedBatchesStayBeyondKeepWithinTheMemoryLimit) {
  // GIVEN a consumer (a store whose disk is full) stuck at seq 20
  Retention r = Filled(100);
  // WHEN pruned with room for all of them
  const Retention::Pruned p =
      r.Prune(/*keep=*/10, /*acknowledged=*/20, /*max_bytes=*/100 * kBatchBytes);
  // THEN only the acknowledged ones beyond `keep` go; 20.. all stay for resends
  EXPECT_EQ(r.first_seq(), 20);
  EXPECT_EQ(r.size(), 80u);
  EXPECT_EQ(p.unacknowledged, 0);
}

TEST(RetentionTest, BeyondTheMemoryLimitTheOldestUnacknowledgedGoAndAreReported) {
  Retention r = Filled(100);
  // A limit of 50 batches' bytes, nothing acknowledged.
  const Retention::Pruned p =
      r.Prune(/*keep=*/10, /*acknowledged=*/0, /*max_bytes=*/50 * kBatchBytes);
  EXPECT_EQ(r.size(), 50u);
  EXPECT_EQ(r.bytes(), 50 * kBatchBytes);
  EXPECT_EQ(p.unacknowledged, 50);
  EXPECT_EQ(p.first_seq, 0);
  EXPECT_EQ(p.last_seq, 49);
  const std::string warning = RetentionExceededWarning("RUN-1", p, 64);
  EXPECT_NE(warning.find("retention limit of 64 MB exceeded"), std::string::npos) << warning;
  EXPECT_NE(warning.find("dropped 50 unacknowledged batches (seq 0..49)"), std::string::npos)
      << warning;
}

}  // namespace
}  // namespace imuqual::acquire
