#include "store/chunk_codec.h"

#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>

namespace imuqual::store {
namespace {

constexpr size_t kHeaderBytes = 6;
constexpr size_t kFlagBytes = 4;
constexpr int kZstdLevel = 1;  // fast: ingest runs at millions of samples a second
// Codec 3 is used when at most this fraction of an axis needs patching.
constexpr double kMaxPatchFraction = 0.05;

static_assert(sizeof(float) == 4, "float32 archive format");

void PutU16(std::vector<uint8_t>& out, uint16_t v) {
  out.push_back(static_cast<uint8_t>(v & 0xff));
  out.push_back(static_cast<uint8_t>(v >> 8));
}
void PutU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int b = 0; b < 4; ++b) out.push_back(static_cast<uint8_t>(v >> (8 * b)));
}
void PutU64(std::vector<uint8_t>& out, uint64_t v) {
  for (int b = 0; b < 8; ++b) out.push_back(static_cast<uint8_t>(v >> (8 * b)));
}
uint16_t GetU16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t GetU32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
uint64_t GetU64(const uint8_t* p) { return GetU32(p) | (static_cast<uint64_t>(GetU32(p + 4)) << 32); }

uint32_t Bits(float v) {
  uint32_t b;
  std::memcpy(&b, &v, 4);
  return b;
}
float FromBits(uint32_t b) {
  float v;
  std::memcpy(&v, &b, 4);
  return v;
}
double DoubleFromBits(uint64_t b) {
  double v;
  std::memcpy(&v, &b, 8);
  return v;
}
uint64_t DoubleBits(double v) {
  uint64_t b;
  std::memcpy(&b, &v, 8);
  return b;
}

// The one way codec 3 rebuilds a value, at encode (to verify) and decode.
float Rebuild(int64_t k, double scale) { return static_cast<float>(static_cast<double>(k) * scale); }

void PutHeader(std::vector<uint8_t>& out, int codec, const ChunkData& c) {
  out.push_back(static_cast<uint8_t>(codec));
  out.push_back(static_cast<uint8_t>(c.num_axes));
  PutU16(out, static_cast<uint16_t>(c.num_samples));
  PutU16(out, static_cast<uint16_t>(c.flags.size()));
}

void PutFlags(std::vector<uint8_t>& out, const std::vector<SampleFlag>& flags) {
  for (const SampleFlag& f : flags) {
    PutU16(out, f.sample);
    out.push_back(f.axis);
    out.push_back(f.bits);
  }
}

Status GetFlags(const uint8_t* p, size_t num_flags, ChunkData* c) {
  for (size_t i = 0; i < num_flags; ++i, p += kFlagBytes) {
    SampleFlag f{GetU16(p), p[2], p[3]};
    if (f.sample >= c->num_samples || f.axis >= c->num_axes) {
      return Status::Corruption("chunk flag points outside the chunk");
    }
    c->flags.push_back(f);
  }
  return Status::Ok();
}

struct CctxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DctxFree {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

// Appends the zstd frame of `body` to *out; false (and *out unchanged) if
// zstd failed, and the caller archives the chunk uncompressed instead.
bool Compress(const std::vector<uint8_t>& body, std::vector<uint8_t>* out) {
  thread_local std::unique_ptr<ZSTD_CCtx, CctxFree> cctx = [] {
    std::unique_ptr<ZSTD_CCtx, CctxFree> c(ZSTD_createCCtx());
    // The frame carries a checksum of its content: damage at rest is
    // detected, not analysed.
    if (c && (ZSTD_isError(ZSTD_CCtx_setParameter(c.get(), ZSTD_c_compressionLevel, kZstdLevel)) ||
              ZSTD_isError(ZSTD_CCtx_setParameter(c.get(), ZSTD_c_checksumFlag, 1)))) {
      c.reset();
    }
    return c;
  }();
  if (!cctx) return false;
  const size_t at = out->size();
  out->resize(at + ZSTD_compressBound(body.size()));
  const size_t n = ZSTD_compress2(cctx.get(), out->data() + at, out->size() - at, body.data(), body.size());
  if (ZSTD_isError(n)) {
    out->resize(at);
    return false;
  }
  out->resize(at + n);
  return true;
}

// The frame's content, which must be at most `max_bytes` long.
Result<std::vector<uint8_t>> Decompress(std::span<const uint8_t> frame, size_t max_bytes) {
  const unsigned long long size = ZSTD_getFrameContentSize(frame.data(), frame.size());
  if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN || size > max_bytes) {
    return Status::Corruption("chunk body is not a zstd frame of the size its header allows");
  }
  thread_local std::unique_ptr<ZSTD_DCtx, DctxFree> dctx(ZSTD_createDCtx());
  std::vector<uint8_t> body(static_cast<size_t>(size));
  const size_t n = ZSTD_decompressDCtx(dctx.get(), body.data(), body.size(), frame.data(), frame.size());
  if (ZSTD_isError(n) || n != body.size()) {
    return Status::Corruption(std::string("chunk body does not decompress: ") +
                              (ZSTD_isError(n) ? ZSTD_getErrorName(n) : "short"));
  }
  return body;
}

// --- codec 2 ---

std::vector<uint8_t> FloatBody(const ChunkData& c) {
  const size_t values = c.samples.size();
  std::vector<uint8_t> body(values * 4);
  for (int a = 0; a < c.num_axes; ++a) {
    uint32_t prev = 0;
    for (int i = 0; i < c.num_samples; ++i) {
      const size_t at = static_cast<size_t>(a) * c.num_samples + i;
      const uint32_t bits = Bits(c.samples[at]);
      const uint32_t x = bits ^ prev;
      prev = bits;
      for (int b = 0; b < 4; ++b) body[b * values + at] = static_cast<uint8_t>(x >> (8 * b));
    }
  }
  PutFlags(body, c.flags);
  return body;
}

Status FromFloatBody(const std::vector<uint8_t>& body, size_t num_flags, ChunkData* c) {
  const size_t values = static_cast<size_t>(c->num_axes) * c->num_samples;
  if (body.size() != values * 4 + num_flags * kFlagBytes) {
    return Status::Corruption("chunk body is " + std::to_string(body.size()) + " bytes, header says " +
                              std::to_string(values * 4 + num_flags * kFlagBytes));
  }
  c->samples.resize(values);
  for (int a = 0; a < c->num_axes; ++a) {
    uint32_t prev = 0;
    for (int i = 0; i < c->num_samples; ++i) {
      const size_t at = static_cast<size_t>(a) * c->num_samples + i;
      uint32_t x = 0;
      for (int b = 0; b < 4; ++b) x |= static_cast<uint32_t>(body[b * values + at]) << (8 * b);
      prev ^= x;
      c->samples[at] = FromBits(prev);
    }
  }
  return GetFlags(body.data() + values * 4, num_flags, c);
}

// --- codec 3 ---

struct Quantized {
  double scale = 1;
  std::vector<int64_t> k;
  std::vector<std::pair<uint16_t, uint32_t>> patches;
};

// Patches needed for `v` at `scale` (k filled in); SIZE_MAX if the scale
// does not fit (|k| too large).
size_t TryScale(std::span<const float> v, double scale, Quantized* q) {
  constexpr double kMaxK = 1LL << 40;
  if (!(scale > 0) || !std::isfinite(scale)) return SIZE_MAX;
  q->scale = scale;
  q->k.assign(v.size(), 0);
  q->patches.clear();
  int64_t prev = 0;
  for (size_t i = 0; i < v.size(); ++i) {
    const double r = static_cast<double>(v[i]) / scale;
    if (std::isfinite(r) && std::abs(r) < kMaxK) {
      const int64_t k = std::llround(r);
      if (Bits(Rebuild(k, scale)) == Bits(v[i])) {
        q->k[i] = prev = k;
        continue;
      }
    }
    q->k[i] = prev;  // a patch: the delta stream stays small
    q->patches.emplace_back(static_cast<uint16_t>(i), Bits(v[i]));
  }
  return q->patches.size();
}

// The reals that round to the float `v` (round to nearest): an interval
// strictly inside the midpoints to its neighbours.
std::pair<double, double> RoundingInterval(float v) {
  const double below = std::nextafter(v, -std::numeric_limits<float>::infinity());
  const double above = std::nextafter(v, std::numeric_limits<float>::infinity());
  const double x = v;
  // Shrunk by a hair: the exact midpoints are ties (round to even).
  return {x - (x - below) * 0.4999999, x + (above - x) * 0.4999999};
}

// A scale that rebuilds v[i] = float(k[i] * scale) for the values whose k
// is `k` (the intersection of every value's interval of scales), near
// `guess`; `guess` if they do not intersect.
double ConsistentScale(std::span<const float> v, double guess) {
  double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
  for (float x : v) {
    if (!std::isfinite(x)) continue;
    const double k = std::round(static_cast<double>(x) / guess);
    if (k == 0 || std::abs(k) > 1e12) continue;
    auto [a, b] = RoundingInterval(x);
    double s1 = a / k, s2 = b / k;
    if (s1 > s2) std::swap(s1, s2);
    lo = std::max(lo, s1);
    hi = std::min(hi, s2);
  }
  return lo <= hi ? 0.5 * (lo + hi) : guess;
}

// The integer quantization of one axis, if it has one: values that are
// float(k * scale) for integers k, with at most kMaxPatchFraction of them
// patched.
bool QuantizeAxis(std::span<const float> v, Quantized* out) {
  const size_t allowed = static_cast<size_t>(kMaxPatchFraction * static_cast<double>(v.size()));
  std::vector<double> finite;
  for (float x : v) {
    if (std::isfinite(x)) finite.push_back(static_cast<double>(x));
  }
  if (finite.size() + allowed < v.size()) return false;
  std::sort(finite.begin(), finite.end());
  finite.erase(std::unique(finite.begin(), finite.end()), finite.end());
  // Spikes are patches, not the scale: look at the central values only.
  const size_t trim = finite.size() / 20;
  finite = std::vector<double>(finite.begin() + static_cast<std::ptrdiff_t>(trim),
                               finite.end() - static_cast<std::ptrdiff_t>(trim));
  double biggest = 0;
  for (double x : finite) biggest = std::max(biggest, std::abs(x));
  if (biggest == 0) return TryScale(v, 1.0, out) <= allowed;  // all zeros
  // A first guess at the quantum: the smallest step between distinct values
  // (one LSB when the noise spans a few; a denormal next to zero is no
  // step), refined on the extremes (their k carries the most digits), then
  // made consistent with every value.
  double step = 0;
  for (size_t i = 1; i < finite.size(); ++i) {
    const double d = finite[i] - finite[i - 1];
    if (d > 1e-9 * biggest && (step == 0 || d < step)) step = d;
  }
  if (step == 0) step = biggest;  // one distinct value
  std::vector<double> guesses = {step};
  for (double x : {finite.front(), finite.back()}) {
    const double k = std::round(std::abs(x) / step);
    if (k >= 1 && k < 1e12) guesses.push_back(std::abs(x) / k);
  }
  Quantized best, trial;
  size_t best_patches = SIZE_MAX;
  for (double guess : guesses) {
    for (double s : {ConsistentScale(v, guess), guess}) {
      const size_t p = TryScale(v, s, &trial);
      if (p < best_patches) {
        best_patches = p;
        best = trial;
      }
      if (p == 0) break;
    }
    if (best_patches == 0) break;
  }
  // Outliers (a spike) leave the intervals without a common point: take the
  // scale the matching values agree on.
  if (best_patches > 0 && best_patches <= v.size() / 2) {
    std::vector<float> matching;
    size_t next_patch = 0;
    for (size_t i = 0; i < v.size(); ++i) {
      if (next_patch < best.patches.size() && best.patches[next_patch].first == i) {
        ++next_patch;
        continue;
      }
      matching.push_back(v[i]);
    }
    const size_t p = TryScale(v, ConsistentScale(matching, best.scale), &trial);
    if (p < best_patches) {
      best_patches = p;
      best = trial;
    }
  }
  if (best_patches > allowed) return false;
  *out = std::move(best);
  return true;
}

void PutVarint(std::vector<uint8_t>& out, uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<uint8_t>(v | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<uint8_t>(v));
}

bool GetVarint(const uint8_t*& p, const uint8_t* end, uint64_t* v) {
  *v = 0;
  for (int shift = 0; shift < 64 && p < end; shift += 7) {
    const uint8_t b = *p++;
    *v |= static_cast<uint64_t>(b & 0x7f) << shift;
    if (!(b & 0x80)) return true;
  }
  return false;
}

uint64_t ZigZag(int64_t v) { return (static_cast<uint64_t>(v) << 1) ^ static_cast<uint64_t>(v >> 63); }
int64_t UnZigZag(uint64_t v) { return static_cast<int64_t>(v >> 1) ^ -static_cast<int64_t>(v & 1); }

constexpr uint8_t kAxisFloat = 0;
constexpr uint8_t kAxisQuantized = 1;

// Codec 3's body: per axis a mode byte, then the quantized form or the
// float form (XOR with the previous value, 4 byte planes); false if no axis
// is quantized (codec 2 is then as good).
constexpr double kFloatReprobeChunks = 16;

bool MixedBody(const ChunkData& c, std::vector<double>* scales, std::vector<uint8_t>* body) {
  if (scales && scales->size() != static_cast<size_t>(c.num_axes)) scales->assign(c.num_axes, 0.0);
  bool any = false;
  Quantized q;
  for (int a = 0; a < c.num_axes; ++a) {
    const std::span<const float> v(c.samples.data() + static_cast<size_t>(a) * c.num_samples,
                                   static_cast<size_t>(c.num_samples));
    // The previous chunk's scale almost always fits the next one; an axis
    // of float noise stays float, so the search (which then fails, at seven
    // times the cost of the compression) runs again only every
    // kFloatReprobeChunks chunks.
    const double hint = scales ? (*scales)[a] : 0.0;
    const bool skip_search = hint < 0 && -hint < kFloatReprobeChunks;
    const bool quantized = (hint > 0 && TryScale(v, hint, &q) == 0) || (!skip_search && QuantizeAxis(v, &q));
    if (scales) (*scales)[a] = quantized ? q.scale : skip_search ? hint - 1 : -1.0;
    if (!quantized) {
      body->push_back(kAxisFloat);
      const size_t at = body->size();
      body->resize(at + v.size() * 4);
      uint32_t prev = 0;
      for (size_t i = 0; i < v.size(); ++i) {
        const uint32_t bits = Bits(v[i]);
        const uint32_t x = bits ^ prev;
        prev = bits;
        for (int byte = 0; byte < 4; ++byte) (*body)[at + byte * v.size() + i] = static_cast<uint8_t>(x >> (8 * byte));
      }
      continue;
    }
    any = true;
    body->push_back(kAxisQuantized);
    PutU64(*body, DoubleBits(q.scale));
    PutU16(*body, static_cast<uint16_t>(q.patches.size()));
    for (const auto& [i, bits] : q.patches) {
      PutU16(*body, i);
      PutU32(*body, bits);
    }
    int64_t prev = 0;
    for (int64_t k : q.k) {
      PutVarint(*body, ZigZag(k - prev));
      prev = k;
    }
  }
  PutFlags(*body, c.flags);
  return any;
}

Status FromMixedBody(const std::vector<uint8_t>& body, size_t num_flags, ChunkData* c) {
  const uint8_t* p = body.data();
  const uint8_t* end = body.data() + body.size();
  const auto corrupt = [](const std::string& what) { return Status::Corruption("compressed chunk: " + what); };
  const size_t n = static_cast<size_t>(c->num_samples);
  c->samples.resize(static_cast<size_t>(c->num_axes) * n);
  for (int a = 0; a < c->num_axes; ++a) {
    float* out = c->samples.data() + static_cast<size_t>(a) * n;
    if (end - p < 1) return corrupt("truncated axis");
    const uint8_t mode = *p++;
    if (mode == kAxisFloat) {
      if (static_cast<size_t>(end - p) < n * 4) return corrupt("truncated float axis");
      uint32_t prev = 0;
      for (size_t i = 0; i < n; ++i) {
        uint32_t x = 0;
        for (int byte = 0; byte < 4; ++byte) x |= static_cast<uint32_t>(p[byte * n + i]) << (8 * byte);
        prev ^= x;
        out[i] = FromBits(prev);
      }
      p += n * 4;
      continue;
    }
    if (mode != kAxisQuantized) return corrupt("unknown axis mode " + std::to_string(mode));
    if (end - p < 10) return corrupt("truncated axis header");
    const double scale = DoubleFromBits(GetU64(p));
    const size_t patches = GetU16(p + 8);
    p += 10;
    if (static_cast<size_t>(end - p) < patches * 6) return corrupt("truncated patches");
    const uint8_t* patch = p;
    p += patches * 6;
    int64_t k = 0;
    for (size_t i = 0; i < n; ++i) {
      uint64_t z;
      if (!GetVarint(p, end, &z)) return corrupt("truncated values");
      k += UnZigZag(z);
      out[i] = Rebuild(k, scale);
    }
    for (size_t j = 0; j < patches; ++j, patch += 6) {
      const uint16_t i = GetU16(patch);
      if (i >= n) return corrupt("patch outside the chunk");
      out[i] = FromBits(GetU32(patch + 2));
    }
  }
  if (static_cast<size_t>(end - p) != num_flags * kFlagBytes) return corrupt("flags do not fit");
  return GetFlags(p, num_flags, c);
}

}  // namespace

namespace {

std::vector<uint8_t> RawChunk(const ChunkData& chunk) {
  std::vector<uint8_t> out;
  out.reserve(kHeaderBytes + chunk.samples.size() * 4 + chunk.flags.size() * kFlagBytes);
  PutHeader(out, kCodecRawFloat32, chunk);
  for (float v : chunk.samples) PutU32(out, Bits(v));
  PutFlags(out, chunk.flags);
  return out;
}

// Codec 3 if the chunk is quantized (else false), codec 2 otherwise; false
// if zstd failed.
bool Compressed(const ChunkData& chunk, bool try_quantized, std::vector<double>* scales,
                EncodedChunk* e) {
  std::vector<uint8_t> body;
  e->data.clear();
  if (try_quantized && MixedBody(chunk, scales, &body)) {
    e->codec = kCodecQuantizedZstd;
  } else {
    body = FloatBody(chunk);
    e->codec = kCodecFloatZstd;
  }
  PutHeader(e->data, e->codec, chunk);
  return Compress(body, &e->data);
}

}  // namespace

std::vector<uint8_t> EncodeChunk(const ChunkData& chunk, int codec) {
  if (codec == kCodecRawFloat32) return RawChunk(chunk);
  EncodedChunk e;
  if ((codec == kCodecFloatZstd || codec == kCodecQuantizedZstd) &&
      Compressed(chunk, codec == kCodecQuantizedZstd, nullptr, &e) && e.codec == codec) {
    return std::move(e.data);
  }
  return {};
}

EncodedChunk EncodeChunkCompact(const ChunkData& chunk, std::vector<double>* scales) {
  EncodedChunk e;
  const size_t raw = kHeaderBytes + chunk.samples.size() * 4 + chunk.flags.size() * kFlagBytes;
  if (Compressed(chunk, true, scales, &e) && e.data.size() < raw) return e;
  return {kCodecRawFloat32, RawChunk(chunk)};
}

Result<ChunkData> DecodeChunk(std::span<const uint8_t> blob, int codec) {
  if (codec != kCodecRawFloat32 && codec != kCodecFloatZstd && codec != kCodecQuantizedZstd) {
    return Status::Corruption("unknown chunk codec " + std::to_string(codec));
  }
  if (blob.size() < kHeaderBytes) return Status::Corruption("chunk shorter than its header");
  if (blob[0] != codec) {
    return Status::Corruption("chunk format version " + std::to_string(blob[0]) + " under codec " +
                              std::to_string(codec));
  }
  ChunkData c;
  c.num_axes = blob[1];
  c.num_samples = GetU16(&blob[2]);
  const size_t num_flags = GetU16(&blob[4]);
  const size_t values = static_cast<size_t>(c.num_axes) * c.num_samples;
  if (c.num_axes == 0) return Status::Corruption("chunk has no axes");
  const std::span<const uint8_t> rest = blob.subspan(kHeaderBytes);
  if (codec == kCodecFloatZstd) {
    auto body = Decompress(rest, values * 4 + num_flags * kFlagBytes);
    if (!body.ok()) return body.status();
    IMUQUAL_RETURN_IF_ERROR(FromFloatBody(*body, num_flags, &c));
    return c;
  }
  if (codec == kCodecQuantizedZstd) {
    // Per axis: mode and header, patches (at most one per value), varints
    // (at most 10 bytes per value); flags.
    const size_t bound = static_cast<size_t>(c.num_axes) * (11 + static_cast<size_t>(c.num_samples) * 16) +
                         num_flags * kFlagBytes;
    auto body = Decompress(rest, bound);
    if (!body.ok()) return body.status();
    IMUQUAL_RETURN_IF_ERROR(FromMixedBody(*body, num_flags, &c));
    return c;
  }
  const size_t want = values * 4 + num_flags * kFlagBytes;
  if (rest.size() != want) {
    return Status::Corruption("chunk is " + std::to_string(blob.size()) + " bytes, header says " +
                              std::to_string(kHeaderBytes + want));
  }
  c.samples.resize(values);
  const uint8_t* p = rest.data();
  for (size_t i = 0; i < values; ++i, p += 4) c.samples[i] = FromBits(GetU32(p));
  IMUQUAL_RETURN_IF_ERROR(GetFlags(p, num_flags, &c));
  return c;
}

}  // namespace imuqual::store
