#include "common/crc32c.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace imuqual {
namespace {

// Bit-at-a-time CRC-32C straight from the definition, to check the tables.
uint32_t ReferenceCrc32c(const std::vector<uint8_t>& bytes) {
  uint32_t crc = 0xFFFFFFFF;
  for (uint8_t b : bytes) {
    crc ^= b;
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ ((crc & 1) ? 0x82F63B78 : 0);
  }
  return ~crc;
}

TEST(Crc32cTest, StandardCheckValue) { EXPECT_EQ(Crc32c("123456789"), 0xE3069283u); }

// RFC 3720 (iSCSI), appendix B.4: CRC examples over 32-byte blocks.
TEST(Crc32cTest, Rfc3720Vectors) {
  std::vector<uint8_t> zeros(32, 0x00), ones(32, 0xFF), up(32), down(32);
  for (int i = 0; i < 32; ++i) {
    up[i] = static_cast<uint8_t>(i);
    down[i] = static_cast<uint8_t>(31 - i);
  }
  EXPECT_EQ(Crc32c(zeros.data(), zeros.size()), 0x8A9136AAu);
  EXPECT_EQ(Crc32c(ones.data(), ones.size()), 0x62A8AB43u);
  EXPECT_EQ(Crc32c(up.data(), up.size()), 0x46DD794Eu);
  EXPECT_EQ(Crc32c(down.data(), down.size()), 0x113FDB5Cu);
  // An iSCSI SCSI Read (10) command PDU.
  const std::vector<uint8_t> read10 = {0x01, 0xC0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                                       0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00, 0x00,
                                       0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00,
                                       0x00, 0x18, 0x28, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                                       0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  EXPECT_EQ(Crc32c(read10.data(), read10.size()), 0xD9963A56u);
}

TEST(Crc32cTest, EmptyMessageIsZero) { EXPECT_EQ(Crc32c(nullptr, 0), 0u); }

TEST(Crc32cTest, EqualsTheBitwiseDefinitionAtEveryLengthAndAlignment) {
  std::mt19937 rng(11);
  std::vector<uint8_t> bytes(300);
  for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng());
  for (size_t offset = 0; offset < 4; ++offset) {
    for (size_t n = 0; n + offset <= bytes.size(); n += 7) {
      std::vector<uint8_t> part(bytes.begin() + offset, bytes.begin() + offset + n);
      EXPECT_EQ(Crc32c(bytes.data() + offset, n), ReferenceCrc32c(part)) << offset << " " << n;
    }
  }
}

TEST(Crc32cTest, ExtendEqualsTheCrcOfTheConcatenation) {
  const std::string a = "bias instability ", b = "from the Allan deviation";
  EXPECT_EQ(Crc32cExtend(Crc32c(a), b.data(), b.size()), Crc32c(a + b));
}

TEST(Crc32cTest, EverySingleBitFlipChangesIt) {
  std::vector<uint8_t> bytes(1400);
  std::mt19937 rng(3);
  for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng());
  const uint32_t clean = Crc32c(bytes.data(), bytes.size());
  for (size_t bit = 0; bit < bytes.size() * 8; ++bit) {
    bytes[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    ASSERT_NE(Crc32c(bytes.data(), bytes.size()), clean) << bit;
    bytes[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
  }
}

// The CPU instruction and the tables agree on every length (0 to 300 bytes,
// so every tail after 8-byte words), every alignment of the start (the
// instruction path aligns to 8 bytes first) and any CRC carried in.
TEST(Crc32cTest, HardwareEqualsPortableAtEveryLengthAlignmentAndStart) {
  if (!Crc32cHardwareAvailable()) GTEST_SKIP() << "no CRC32 instruction on this CPU";
  std::mt19937 rng(17);
  std::vector<uint8_t> bytes(320);
  for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng());
  for (uint32_t start : {0u, 0xFFFFFFFFu, 0xE3069283u}) {
    for (size_t offset = 0; offset < 8; ++offset) {
      for (size_t n = 0; n + offset <= 300; ++n) {
        ASSERT_EQ(Crc32cExtendHardware(start, bytes.data() + offset, n),
                  Crc32cExtendPortable(start, bytes.data() + offset, n))
            << start << " " << offset << " " << n;
      }
    }
  }
  // A batch-sized message (the bus seals 8 KB datagrams).
  std::vector<uint8_t> batch(8200);
  for (uint8_t& b : batch) b = static_cast<uint8_t>(rng());
  EXPECT_EQ(Crc32cExtendHardware(0, batch.data(), batch.size()),
            Crc32cExtendPortable(0, batch.data(), batch.size()));
}

TEST(Crc32cTest, PortableMeetsTheCheckValueAndTheDefinition) {
  // Crc32c may use the instruction; the tables are checked on their own too.
  EXPECT_EQ(Crc32cExtendPortable(0, "123456789", 9), 0xE3069283u);
  std::mt19937 rng(5);
  std::vector<uint8_t> bytes(77);
  for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng());
  EXPECT_EQ(Crc32cExtendPortable(0, bytes.data(), bytes.size()), ReferenceCrc32c(bytes));
}

}  // namespace
}  // namespace imuqual
