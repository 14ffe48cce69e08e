// The chunk codecs: every codec gives back exactly the float32 bits it was
// given, whatever the values (NaN, -0, denormals, spikes, pure noise); the
// compact choice picks the quantized codec for quantized sensors; sizes are
// what the archive budget assumes; lies and damage are Corruption errors.
#include "store/chunk_codec.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

namespace imuqual::store {
namespace {

ChunkData Chunk(int axes, int samples, const std::function<float(int, int)>& value) {
  ChunkData d;
  d.num_axes = axes;
  d.num_samples = samples;
  for (int a = 0; a < axes; ++a) {
    for (int i = 0; i < samples; ++i) d.samples.push_back(value(a, i));
  }
  return d;
}

void ExpectBitExact(const ChunkData& want, const ChunkData& got) {
  ASSERT_EQ(got.num_axes, want.num_axes);
  ASSERT_EQ(got.num_samples, want.num_samples);
  ASSERT_EQ(got.samples.size(), want.samples.size());
  for (size_t i = 0; i < want.samples.size(); ++i) {
    uint32_t a, b;
    std::memcpy(&a, &want.samples[i], 4);
    std::memcpy(&b, &got.samples[i], 4);
    ASSERT_EQ(a, b) << "value " << i << ": " << want.samples[i] << " came back " << got.samples[i];
  }
  EXPECT_EQ(got.flags, want.flags);
}

EncodedChunk RoundTrip(const ChunkData& d) {
  EncodedChunk e = EncodeChunkCompact(d);
  auto back = DecodeChunk(e.data, e.codec);
  EXPECT_TRUE(back.ok()) << back.status().message();
  if (back.ok()) ExpectBitExact(d, *back);
  for (int codec : {kCodecRawFloat32, kCodecFloatZstd}) {
    const std::vector<uint8_t> blob = EncodeChunk(d, codec);
    auto again = DecodeChunk(blob, codec);
    EXPECT_TRUE(again.ok()) << codec;
    if (again.ok()) ExpectBitExact(d, *again);
  }
  return e;
}

double BytesPerValue(const EncodedChunk& e, const ChunkData& d) {
  return static_cast<double>(e.data.size()) / static_cast<double>(d.samples.size());
}

TEST(ChunkCodecTest, FloatNoiseRoundTripsAndCompresses) {
  std::mt19937 rng(1);
  std::normal_distribution<float> g(0.0f, 1.0f);
  // A gyro at 0.01 deg/s offset with 0.005 deg/s noise, an accelerometer at 1 g.
  ChunkData d = Chunk(6, 200, [&](int a, int) {
    return a < 3 ? 0.01f + 0.005f * g(rng) : (a == 5 ? 9.80665f : 0.0f) + 0.002f * g(rng);
  });
  d.flags = {{3, 1, 1}, {199, 5, 2}};
  const EncodedChunk e = RoundTrip(d);
  // Float planes; or fixed point where an axis stays in one binade (near
  // 1 g every float32 is a multiple of 2^-20).
  EXPECT_NE(e.codec, kCodecRawFloat32);
  EXPECT_LT(BytesPerValue(e, d), 3.7);  // 23 random mantissa bits cannot be squeezed much
}

TEST(ChunkCodecTest, QuantizedSensorsTakeTheQuantizedCodec) {
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0.0, 1.0);
  // Typical scale factors: 8.75 mdps/LSB (MEMS gyro), 1/3 (not a binary
  // fraction), 0.061 mg/LSB in m/s^2, and the simulator's (k q) / tau0.
  const double scales[] = {0.00875, 1.0 / 3.0, 0.061e-3 * 9.80665};
  for (double scale : scales) {
    ChunkData d = Chunk(3, 200, [&](int a, int) {
      const int64_t k = std::llround(1000 * a + 20 * g(rng));  // about 20 LSB of noise
      return static_cast<float>(static_cast<double>(k) * scale);
    });
    const EncodedChunk e = RoundTrip(d);
    EXPECT_EQ(e.codec, kCodecQuantizedZstd) << scale;
    EXPECT_LT(BytesPerValue(e, d), 1.5) << scale;
  }
  const double q = 0.0004, tau0 = 0.01;
  ChunkData sim = Chunk(3, 200, [&](int, int) {
    const double k = std::floor(5 * g(rng));
    return static_cast<float>(k * q / tau0);
  });
  EXPECT_EQ(RoundTrip(sim).codec, kCodecQuantizedZstd);
}

TEST(ChunkCodecTest, QuantizedWithSpikesNansAndNegativeZeroPatches) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> lsb(-300, 300);
  ChunkData d = Chunk(2, 300, [&](int, int) { return static_cast<float>(lsb(rng) * 0.0125); });
  d.samples[17] = std::numeric_limits<float>::quiet_NaN();
  d.samples[18] = -0.0f;
  d.samples[300 + 5] = 1e30f;
  d.samples[300 + 6] = std::numeric_limits<float>::denorm_min();
  const EncodedChunk e = RoundTrip(d);
  EXPECT_EQ(e.codec, kCodecQuantizedZstd);
  // Mostly not quantized: the float codec.
  ChunkData noisy = d;
  std::uniform_real_distribution<float> u(-1, 1);
  for (int i = 0; i < 60; ++i) noisy.samples[i * 10 + 1] = u(rng);
  EXPECT_EQ(RoundTrip(noisy).codec, kCodecFloatZstd);
}

TEST(ChunkCodecTest, DegenerateAxesAndIncompressibleBits) {
  RoundTrip(Chunk(1, 1, [](int, int) { return 0.0f; }));
  RoundTrip(Chunk(2, 50, [](int, int) { return 0.0f; }));
  RoundTrip(Chunk(2, 50, [](int a, int) { return a ? -3.25f : 7.0f; }));
  RoundTrip(Chunk(1, 40, [](int, int i) { return i % 2 ? std::numeric_limits<float>::max() : -1e-45f; }));
  RoundTrip(Chunk(3, 0, [](int, int) { return 0.0f; }));
  // Random bit patterns (NaNs of every payload included): nothing to gain,
  // the raw codec, still exact.
  std::mt19937 rng(4);
  const EncodedChunk e = RoundTrip(Chunk(4, 100, [&](int, int) {
    const uint32_t bits = rng();
    float v;
    std::memcpy(&v, &bits, 4);
    return v;
  }));
  EXPECT_EQ(e.codec, kCodecRawFloat32);
}

TEST(ChunkCodecTest, RefusesWhatItCannotHold) {
  std::mt19937 rng(5);
  std::normal_distribution<float> g;
  const ChunkData noise = Chunk(2, 64, [&](int, int) { return g(rng); });
  EXPECT_TRUE(EncodeChunk(noise, kCodecQuantizedZstd).empty());
  EXPECT_TRUE(EncodeChunk(noise, 7).empty());
}

TEST(ChunkCodecTest, DamagedCompressedChunksAreCorruption) {
  std::mt19937 rng(6);
  std::normal_distribution<double> g;
  const ChunkData quantized = Chunk(3, 100, [&](int, int) { return static_cast<float>(std::round(9 * g(rng)) * 0.5); });
  const ChunkData noise = Chunk(3, 100, [&](int, int) { return static_cast<float>(g(rng)); });
  for (const ChunkData* d : {&quantized, &noise}) {
    const EncodedChunk e = EncodeChunkCompact(*d);
    ASSERT_NE(e.codec, kCodecRawFloat32);
    // Truncated anywhere, a header that lies about the size, the codec column
    // disagreeing with the header, a flipped byte in the frame.
    for (size_t cut = 0; cut < e.data.size(); cut += 7) {
      EXPECT_FALSE(DecodeChunk(std::span(e.data).first(cut), e.codec).ok()) << cut;
    }
    std::vector<uint8_t> lie = e.data;
    lie[2] ^= 0x01;  // num_samples
    EXPECT_FALSE(DecodeChunk(lie, e.codec).ok());
    EXPECT_FALSE(DecodeChunk(e.data, kCodecRawFloat32).ok());
    // The frame's checksum catches damage anywhere in it: a flipped bit is
    // detected, or was in a frame field that changes nothing decoded.
    int detected = 0;
    for (size_t at = 6; at < e.data.size(); ++at) {
      std::vector<uint8_t> flipped = e.data;
      flipped[at] ^= 0x40;
      auto r = DecodeChunk(flipped, e.codec);
      if (!r.ok()) {
        ++detected;
        continue;
      }
      ExpectBitExact(*d, *r);
    }
    EXPECT_GT(detected, static_cast<int>(e.data.size()) - 6 - 4);
  }
}

}  // namespace
}  // namespace imuqual::store
