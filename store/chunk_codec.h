// Raw chunk BLOBs: the samples of one rate batch as archived. Lossless: a
// decoded chunk holds exactly the float32 values acquire published, so
// re-analysis from the archive reproduces the live analysis bit for bit.
//
// Codec 1 (raw), little-endian:
//   u8 version (1) | u8 num_axes | u16 num_samples | u16 num_flags
//   | f32 samples[num_axes][num_samples]
//   | num_flags x { u16 sample, u8 axis, u8 bits }
#ifndef IMUQUAL_STORE_CHUNK_CODEC_H_
#define IMUQUAL_STORE_CHUNK_CODEC_H_

#include <cstdint>
#include <span>
#include <vector>

#include "common/status.h"

namespace imuqual::store {

inline constexpr int kCodecRawFloat32 = 1;

struct SampleFlag {
  uint16_t sample = 0;  // index within the chunk
  uint8_t axis = 0;
  uint8_t bits = 0;     // rate_batch_t FLAG_* bits
  bool operator==(const SampleFlag&) const = default;
};

struct ChunkData {
  int num_axes = 0;
  int num_samples = 0;
  std::vector<float> samples;     // axis-major: samples[a * num_samples + i]
  std::vector<SampleFlag> flags;  // sparse
  float at(int axis, int i) const { return samples[static_cast<size_t>(axis) * num_samples + i]; }
};

// Precondition: samples.size() == num_axes * num_samples, 1 <= num_axes <= 255,
// num_samples <= 65535, flags index inside the chunk.
std::vector<uint8_t> EncodeChunk(const ChunkData& chunk, int codec);
// Checks every length against the BLOB; a lying or truncated BLOB is a
// Corruption error, never a crash.
Result<ChunkData> DecodeChunk(std::span<const uint8_t> blob, int codec);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_CHUNK_CODEC_H_
