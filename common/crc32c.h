// CRC-32C (Castagnoli), the checksum of iSCSI (RFC 3720), ext4 and SCTP:
// polynomial 0x1EDC6F41, bit-reflected (0x82F63B78), initial value and final
// XOR 0xFFFFFFFF. It detects every error of up to 5 flipped bits in messages
// up to ~ 2^31 bits long and every burst of up to 32 bits, which is what a
// flipped bit in a datagram or a damaged page at rest looks like.
//
// Check value: Crc32c("123456789") == 0xE3069283.
#ifndef IMUQUAL_COMMON_CRC32C_H_
#define IMUQUAL_COMMON_CRC32C_H_

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace imuqual {

// The CRC-32C of `crc`'s message followed by `size` bytes at `data`:
// Crc32cExtend(Crc32c(a), b) == Crc32c(a + b). Start a message with 0.
uint32_t Crc32cExtend(uint32_t crc, const void* data, size_t size);

inline uint32_t Crc32c(const void* data, size_t size) { return Crc32cExtend(0, data, size); }
inline uint32_t Crc32c(std::string_view bytes) { return Crc32c(bytes.data(), bytes.size()); }

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_CRC32C_H_
