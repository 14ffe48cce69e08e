// CRC-32C (Castagnoli), the checksum of iSCSI (RFC 3720), ext4 and SCTP:
// polynomial 0x1EDC6F41, bit-reflected (0x82F63B78), initial value and final
// XOR 0xFFFFFFFF. It detects every error of up to 5 flipped bits in messages
// up to ~ 2^31 bits long and every burst of up to 32 bits, which is what a
// flipped bit in a datagram or a damaged page at rest looks like.
//
// Check value: Crc32c("123456789") == 0xE3069283.
//
// Two implementations give the same value for every input: the SSE4.2
// instruction CRC32 (x86-64, 8 bytes per instruction, about 10x the tables'
// speed), used when the CPU has it (checked once, at the first call), and a
// portable slicing-by-4 table implementation everywhere else. Thread-safe.
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

// The implementations behind Crc32cExtend, for tests and benchmarks: the
// portable tables, and the CPU instruction (only where
// Crc32cHardwareAvailable(); elsewhere it must not be called).
uint32_t Crc32cExtendPortable(uint32_t crc, const void* data, size_t size);
uint32_t Crc32cExtendHardware(uint32_t crc, const void* data, size_t size);
// Whether this CPU has the CRC32 instruction (SSE4.2) and this build uses it.
bool Crc32cHardwareAvailable();

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_CRC32C_H_
