#include "common/batch_integrity.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/lcm_bus.h"

namespace imuqual {
namespace {

// A small batch with every kind of field set: strings, counters, samples on
// two axes, a flag, a temperature and the times.
imuqual::rate_batch_t SmallBatch() {
  imuqual::rate_batch_t b;
  b.host_utime = 1700000000123456;
  b.run_id = "R-U01";
  b.unit_serial = "U01";
  b.seq = 42;
  b.first_sample = 4200;
  b.nominal_rate_hz = 100;
  b.num_axes = 2;
  b.axis_names = {"x", "ax"};
  b.axis_kinds = {imuqual::rate_batch_t::KIND_GYRO, imuqual::rate_batch_t::KIND_ACCEL};
  b.num_samples = 6;
  b.samples = {{0.01f, -0.02f, 0.03f, 0.0f, 1e-3f, -5e-4f},
               {9.81f, 9.80f, 9.82f, 9.81f, 9.79f, 9.81f}};
  b.num_flagged = 1;
  b.flagged_sample = {3};
  b.flagged_axis = {0};
  b.flagged_bits = {imuqual::rate_batch_t::FLAG_SATURATED};
  b.has_temperature = true;
  b.temperature_c = 25.5f;
  b.sample_utime = 1700000000100000;
  return b;
}

TEST(BatchIntegrityTest, ASealedBatchVerifiesAfterTheBus) {
  imuqual::rate_batch_t b = SmallBatch();
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeSealedBatch(&b, &bytes).ok());
  imuqual::rate_batch_t received;
  ASSERT_TRUE(DecodeExactly(bytes.data(), static_cast<int>(bytes.size()), &received).ok());
  EXPECT_EQ(received.crc32c, b.crc32c);
  EXPECT_TRUE(VerifyBatch(received).ok());
  EXPECT_TRUE(VerifyBatch(b).ok());
}

TEST(BatchIntegrityTest, AnUnsealedBatchIsDamaged) {
  imuqual::rate_batch_t b = SmallBatch();
  b.crc32c = 0;
  Status st = VerifyBatch(b);
  EXPECT_EQ(st.code(), Status::Code::kCorruption);
  EXPECT_NE(st.message().find("R-U01"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("seq 42"), std::string::npos) << st.message();
}

TEST(BatchIntegrityTest, EveryFieldIsCovered) {
  imuqual::rate_batch_t sealed = SmallBatch();
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeSealedBatch(&sealed, &bytes).ok());
  auto damaged = [&](auto change) {
    imuqual::rate_batch_t b = sealed;
    change(b);
    return !VerifyBatch(b).ok();
  };
  EXPECT_TRUE(damaged([](auto& b) { b.host_utime += 1; }));
  EXPECT_TRUE(damaged([](auto& b) { b.run_id = "R-U02"; }));
  EXPECT_TRUE(damaged([](auto& b) { b.unit_serial = "U02"; }));
  EXPECT_TRUE(damaged([](auto& b) { b.seq += 1; }));
  EXPECT_TRUE(damaged([](auto& b) { b.first_sample += 1; }));
  EXPECT_TRUE(damaged([](auto& b) { b.nominal_rate_hz = 200; }));
  EXPECT_TRUE(damaged([](auto& b) { b.axis_names[1] = "ay"; }));
  EXPECT_TRUE(damaged([](auto& b) { b.axis_kinds[1] = imuqual::rate_batch_t::KIND_GYRO; }));
  EXPECT_TRUE(damaged([](auto& b) { b.samples[1][5] = 9.811f; }));
  EXPECT_TRUE(damaged([](auto& b) { b.flagged_sample[0] = 4; }));
  EXPECT_TRUE(damaged([](auto& b) { b.flagged_axis[0] = 1; }));
  EXPECT_TRUE(damaged([](auto& b) { b.flagged_bits[0] = imuqual::rate_batch_t::FLAG_INVALID; }));
  EXPECT_TRUE(damaged([](auto& b) { b.has_temperature = false; }));
  EXPECT_TRUE(damaged([](auto& b) { b.temperature_c = 25.25f; }));
  EXPECT_TRUE(damaged([](auto& b) { b.sample_utime -= 1; }));
  EXPECT_TRUE(damaged([](auto& b) { b.crc32c ^= 1; }));
}

// GIVEN a sealed batch on the wire WHEN any one bit of the datagram flips
// THEN the receiver either cannot decode it or finds the checksum wrong:
// no single-bit damage reaches the analysis or the archive.
TEST(BatchIntegrityTest, EverySingleBitFlipIsRejected) {
  imuqual::rate_batch_t b = SmallBatch();
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeSealedBatch(&b, &bytes).ok());
  int undecodable = 0, checksum_wrong = 0;
  for (size_t bit = 0; bit < bytes.size() * 8; ++bit) {
    std::vector<uint8_t> damaged = bytes;
    damaged[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    imuqual::rate_batch_t received;
    if (!DecodeExactly(damaged.data(), static_cast<int>(damaged.size()), &received).ok()) {
      ++undecodable;
      continue;
    }
    ASSERT_FALSE(VerifyBatch(received).ok()) << "bit " << bit << " went through";
    ++checksum_wrong;
  }
  EXPECT_EQ(undecodable + checksum_wrong, static_cast<int>(bytes.size() * 8));
  // The samples alone are 48 of the bytes: only the checksum sees those.
  EXPECT_GE(checksum_wrong, 48 * 8);
}

}  // namespace
}  // namespace imuqual
