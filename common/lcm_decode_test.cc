// The generated decoders, hardened at build time (lcmtypes/harden_decode.cmake),
// refuse messages whose length fields lie, without allocating what the lie
// claims and without throwing.
#include <gtest/gtest.h>

#include <climits>
#include <cstring>

#include "common/lcm_bus.h"
#include "imuqual/decision_t.hpp"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/run_t.hpp"

namespace imuqual {
namespace {

imuqual::rate_batch_t ValidBatch() {
  imuqual::rate_batch_t b{};
  b.run_id = "RUN";
  b.unit_serial = "U1";
  b.seq = 1;
  b.first_sample = 100;
  b.nominal_rate_hz = 100;
  b.num_axes = 2;
  b.axis_names = {"x", "y"};
  b.axis_kinds = {1, 1};
  b.num_samples = 3;
  b.samples = {{1, 2, 3}, {4, 5, 6}};
  b.num_flagged = 0;
  return b;
}

void PutInt32(std::vector<uint8_t>* bytes, size_t offset, int32_t v) {
  const uint32_t u = static_cast<uint32_t>(v);
  for (int i = 0; i < 4; ++i) (*bytes)[offset + i] = static_cast<uint8_t>(u >> (24 - 8 * i));
}

// Offset of the run_id length field: after the fingerprint and host_utime.
constexpr size_t kRunIdLength = 8 + 8;

TEST(LcmDecodeTest, AValidMessageDecodesExactly) {
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeMessage(ValidBatch(), &bytes).ok());
  imuqual::rate_batch_t out;
  ASSERT_TRUE(DecodeExactly(bytes.data(), static_cast<int>(bytes.size()), &out).ok());
  EXPECT_EQ(out.samples[1][2], 6.0f);
  // A trailing byte is refused too.
  bytes.push_back(0);
  EXPECT_FALSE(DecodeExactly(bytes.data(), static_cast<int>(bytes.size()), &out).ok());
}

TEST(LcmDecodeTest, StringLengthsThatLieAreRefused) {
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeMessage(ValidBatch(), &bytes).ok());
  for (int32_t lie : {0, -1, INT_MIN, INT_MAX, 1 << 20}) {
    std::vector<uint8_t> bad = bytes;
    PutInt32(&bad, kRunIdLength, lie);
    imuqual::rate_batch_t out;
    const Status st = DecodeExactly(bad.data(), static_cast<int>(bad.size()), &out);
    EXPECT_FALSE(st.ok()) << lie;
    EXPECT_EQ(st.code(), Status::Code::kCorruption) << lie;
  }
}

TEST(LcmDecodeTest, StringsWithAnEmbeddedNulAreRefused) {
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeMessage(ValidBatch(), &bytes).ok());
  std::vector<uint8_t> bad = bytes;
  bad[kRunIdLength + 4 + 1] = 0;  // "RUN" -> "R\0N"
  imuqual::rate_batch_t out;
  EXPECT_FALSE(DecodeExactly(bad.data(), static_cast<int>(bad.size()), &out).ok());
}

TEST(LcmDecodeTest, ArrayCountsThatLieAreRefusedBeforeAllocating) {
  imuqual::run_t run{};
  run.run_id = "R";
  run.unit_serial = "U";
  run.num_axes = 0;
  run.plan_size = 4;
  run.plan = {1, 2, 3, 4};
  run.truth_size = 0;
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeMessage(run, &bytes).ok());
  // plan_size follows: utime, 8 strings, utime, rate, num_axes; find it by value.
  size_t at = 0;
  for (size_t i = 0; i + 8 <= bytes.size(); ++i) {
    if (bytes[i] == 0 && bytes[i + 1] == 0 && bytes[i + 2] == 0 && bytes[i + 3] == 4 &&
        bytes[i + 4] == 1 && bytes[i + 5] == 2) {
      at = i;
    }
  }
  ASSERT_GT(at, 0u);
  for (int32_t lie : {-1, INT_MAX, 1 << 30}) {
    std::vector<uint8_t> bad = bytes;
    PutInt32(&bad, at, lie);
    imuqual::run_t out;
    EXPECT_FALSE(DecodeExactly(bad.data(), static_cast<int>(bad.size()), &out).ok()) << lie;
    EXPECT_LE(out.plan.capacity(), bytes.size()) << "allocated for the lie " << lie;
  }
}

// decision_t's pending reasons: an array of strings, decoded in a loop; a
// count that lies (negative, or beyond the bytes there) is refused.
TEST(LcmDecodeTest, DecisionPendingCountsThatLieAreRefused) {
  imuqual::decision_t d{};
  d.run_id = "R";
  d.unit_serial = "U";
  d.state = imuqual::decision_t::STATE_PENDING;
  d.num_pending = 2;
  d.pending = {"x: bias_instability: not measured yet", "y: angle_random_walk: not measured yet"};
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeMessage(d, &bytes).ok());
  imuqual::decision_t out;
  ASSERT_TRUE(DecodeExactly(bytes.data(), static_cast<int>(bytes.size()), &out).ok());
  EXPECT_EQ(out.pending, d.pending);
  // num_pending (int16) follows the fingerprint, host_utime, run_id "R",
  // unit_serial "U", revision, state, the two look counts, decided_at_s,
  // end_sample and z.
  constexpr size_t kNumPending = 8 + 8 + (4 + 2) + (4 + 2) + 2 + 1 + 2 + 2 + 8 + 8 + 8;
  ASSERT_EQ(bytes[kNumPending], 0);
  ASSERT_EQ(bytes[kNumPending + 1], 2);
  for (int16_t lie : {int16_t{-1}, int16_t{3}, int16_t{32767}}) {
    std::vector<uint8_t> bad = bytes;
    bad[kNumPending] = static_cast<uint8_t>(static_cast<uint16_t>(lie) >> 8);
    bad[kNumPending + 1] = static_cast<uint8_t>(lie & 0xff);
    EXPECT_FALSE(DecodeExactly(bad.data(), static_cast<int>(bad.size()), &out).ok()) << lie;
  }
}

}  // namespace
}  // namespace imuqual
