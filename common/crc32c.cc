#include "common/crc32c.h"

#include <array>
#include <cstring>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <nmmintrin.h>
#define IMUQUAL_CRC32C_SSE42 1
#endif

namespace imuqual {
namespace {

constexpr uint32_t kReflectedPolynomial = 0x82F63B78;

// Slicing-by-4: table[0] is the classic byte-at-a-time table (the CRC of
// each byte value); table[k][b] is the CRC of byte b followed by k zero
// bytes, so four input bytes are folded in with four lookups.
using Tables = std::array<std::array<uint32_t, 256>, 4>;

constexpr Tables MakeTables() {
  Tables t{};
  for (uint32_t b = 0; b < 256; ++b) {
    uint32_t crc = b;
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ ((crc & 1) ? kReflectedPolynomial : 0);
    t[0][b] = crc;
  }
  for (uint32_t b = 0; b < 256; ++b) {
    for (int k = 1; k < 4; ++k) t[k][b] = (t[k - 1][b] >> 8) ^ t[0][t[k - 1][b] & 0xFF];
  }
  return t;
}

constexpr Tables kTables = MakeTables();

#ifdef IMUQUAL_CRC32C_SSE42
// The CRC32 instruction computes the same reflected CRC-32C register update
// as the tables (Intel SDM, CRC32: polynomial 0x11EDC6F41), one byte or eight
// bytes at a time; the register is inverted on entry and exit as above.
__attribute__((target("sse4.2"))) uint32_t Sse42Extend(uint32_t crc, const uint8_t* p,
                                                       size_t size) {
  uint64_t c = ~crc;
  while (size > 0 && (reinterpret_cast<uintptr_t>(p) & 7) != 0) {
    c = _mm_crc32_u8(static_cast<uint32_t>(c), *p++);
    --size;
  }
  while (size >= 8) {
    uint64_t word;
    std::memcpy(&word, p, 8);  // little-endian: the first byte is folded in first
    c = _mm_crc32_u64(c, word);
    p += 8;
    size -= 8;
  }
  while (size-- > 0) c = _mm_crc32_u8(static_cast<uint32_t>(c), *p++);
  return ~static_cast<uint32_t>(c);
}
#endif

using ExtendFunction = uint32_t (*)(uint32_t, const void*, size_t);

ExtendFunction PickExtend() {
  return Crc32cHardwareAvailable() ? &Crc32cExtendHardware : &Crc32cExtendPortable;
}

}  // namespace

uint32_t Crc32cExtendPortable(uint32_t crc, const void* data, size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  uint32_t c = ~crc;
  while (size >= 4) {
    c ^= uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16 | uint32_t{p[3]} << 24;
    c = kTables[3][c & 0xFF] ^ kTables[2][(c >> 8) & 0xFF] ^ kTables[1][(c >> 16) & 0xFF] ^
        kTables[0][c >> 24];
    p += 4;
    size -= 4;
  }
  while (size-- > 0) c = (c >> 8) ^ kTables[0][(c ^ *p++) & 0xFF];
  return ~c;
}

bool Crc32cHardwareAvailable() {
#ifdef IMUQUAL_CRC32C_SSE42
  static const bool available = [] {
    __builtin_cpu_init();  // callable before main (another static's initializer)
    return __builtin_cpu_supports("sse4.2") != 0;
  }();
  return available;
#else
  return false;
#endif
}

uint32_t Crc32cExtendHardware(uint32_t crc, const void* data, size_t size) {
#ifdef IMUQUAL_CRC32C_SSE42
  return Sse42Extend(crc, static_cast<const uint8_t*>(data), size);
#else
  return Crc32cExtendPortable(crc, data, size);  // never called: not available
#endif
}

uint32_t Crc32cExtend(uint32_t crc, const void* data, size_t size) {
  static const ExtendFunction extend = PickExtend();
  return extend(crc, data, size);
}

}  // namespace imuqual
