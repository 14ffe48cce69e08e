// Raw chunk BLOBs: the samples of one rate batch as archived. Lossless: a
// decoded chunk holds exactly the float32 values acquire published, so
// re-analysis from the archive reproduces the live analysis bit for bit.
// Every codec starts with the same header, little-endian:
//   u8 version (= codec) | u8 num_axes | u16 num_samples | u16 num_flags
// then:
// Codec 1 (raw):
//   f32 samples[num_axes][num_samples] | num_flags x { u16 sample, u8 axis, u8 bits }
// Codec 2 (float, compressed): a zstd frame of the codec 1 body with each
//   value's bits XORed with the previous value of its axis (the sign,
//   exponent and leading mantissa bits of a noisy sensor rarely change) and
//   the result split into 4 byte planes (all lowest bytes, then ..., then
//   all highest bytes), flags after.
// Codec 3 (mixed, compressed): for integer-quantized sensors, whose values
//   are float32(k * scale) for integers k: a zstd frame (with checksum) of,
//   per axis, u8 mode then
//     mode 1 (quantized): f64 scale | u16 num_patches
//       | num_patches x { u16 sample, u32 float bits } | zigzag varints of k[i] - k[i-1]
//     mode 0 (float): that axis's values as in codec 2 (XOR, 4 byte planes)
//   then the flags. A patch holds a value the scale does not rebuild bit
//   for bit (a NaN, a spike): the encoder verifies every value and takes
//   mode 1 only when few need patching.
#ifndef IMUQUAL_STORE_CHUNK_CODEC_H_
#define IMUQUAL_STORE_CHUNK_CODEC_H_

#include <cstdint>
#include <span>
#include <vector>

#include "common/status.h"

namespace imuqual::store {

inline constexpr int kCodecRawFloat32 = 1;
inline constexpr int kCodecFloatZstd = 2;
inline constexpr int kCodecQuantizedZstd = 3;

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

struct EncodedChunk {
  int codec = 0;
  std::vector<uint8_t> data;
};

// Preconditions (both encoders): samples.size() == num_axes * num_samples,
// 1 <= num_axes <= 255, num_samples <= 65535, flags index inside the chunk.
// The chunk in `codec`; empty when that codec cannot hold it (codec 3 for
// a chunk with no quantized axis, a zstd failure).
std::vector<uint8_t> EncodeChunk(const ChunkData& chunk, int codec);
// What the archive stores: codec 3 when some axis is quantized, else codec
// 2, or codec 1 when compression does not pay. Always succeeds.
// `scales` (optional, one per axis, start with 0 = unknown) carries each
// axis's scale from one chunk of a run to the next: tried first, it spares
// the search that finds a quantized sensor's scale; updated with the scales
// used. A negative entry counts the float chunks in a row of an axis that
// has no scale: the search is retried only every 16 of them. Lossless
// either way; only the size can differ.
EncodedChunk EncodeChunkCompact(const ChunkData& chunk, std::vector<double>* scales = nullptr);
// Checks every length against the BLOB; a lying or truncated BLOB is a
// Corruption error, never a crash.
Result<ChunkData> DecodeChunk(std::span<const uint8_t> blob, int codec);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_CHUNK_CODEC_H_
