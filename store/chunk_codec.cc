#include "store/chunk_codec.h"

#include <cstring>
#include <string>

namespace imuqual::store {
namespace {

constexpr size_t kHeaderBytes = 6;
constexpr size_t kFlagBytes = 4;

void PutU16(std::vector<uint8_t>& out, uint16_t v) {
  out.push_back(static_cast<uint8_t>(v & 0xff));
  out.push_back(static_cast<uint8_t>(v >> 8));
}
uint16_t GetU16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

static_assert(sizeof(float) == 4, "float32 archive format");

}  // namespace

std::vector<uint8_t> EncodeChunk(const ChunkData& chunk, int codec) {
  (void)codec;  // only kCodecRawFloat32 so far
  std::vector<uint8_t> out;
  out.reserve(kHeaderBytes + chunk.samples.size() * 4 + chunk.flags.size() * kFlagBytes);
  out.push_back(1);
  out.push_back(static_cast<uint8_t>(chunk.num_axes));
  PutU16(out, static_cast<uint16_t>(chunk.num_samples));
  PutU16(out, static_cast<uint16_t>(chunk.flags.size()));
  for (float v : chunk.samples) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    for (int b = 0; b < 4; ++b) out.push_back(static_cast<uint8_t>(bits >> (8 * b)));
  }
  for (const SampleFlag& f : chunk.flags) {
    PutU16(out, f.sample);
    out.push_back(f.axis);
    out.push_back(f.bits);
  }
  return out;
}

Result<ChunkData> DecodeChunk(std::span<const uint8_t> blob, int codec) {
  if (codec != kCodecRawFloat32) {
    return Status::Corruption("unknown chunk codec " + std::to_string(codec));
  }
  if (blob.size() < kHeaderBytes) return Status::Corruption("chunk shorter than its header");
  if (blob[0] != 1) return Status::Corruption("chunk format version " + std::to_string(blob[0]));
  ChunkData c;
  c.num_axes = blob[1];
  c.num_samples = GetU16(&blob[2]);
  const size_t num_flags = GetU16(&blob[4]);
  const size_t values = static_cast<size_t>(c.num_axes) * c.num_samples;
  const size_t want = kHeaderBytes + values * 4 + num_flags * kFlagBytes;
  if (c.num_axes == 0) return Status::Corruption("chunk has no axes");
  if (blob.size() != want) {
    return Status::Corruption("chunk is " + std::to_string(blob.size()) + " bytes, header says " +
                              std::to_string(want));
  }
  c.samples.resize(values);
  const uint8_t* p = blob.data() + kHeaderBytes;
  for (size_t i = 0; i < values; ++i, p += 4) {
    const uint32_t bits = static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
                          (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
    std::memcpy(&c.samples[i], &bits, 4);
  }
  for (size_t i = 0; i < num_flags; ++i, p += kFlagBytes) {
    SampleFlag f{GetU16(p), p[2], p[3]};
    if (f.sample >= c.num_samples || f.axis >= c.num_axes) {
      return Status::Corruption("chunk flag points outside the chunk");
    }
    c.flags.push_back(f);
  }
  return c;
}

}  // namespace imuqual::store
