#include "acquire/crossbow_protocol.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "imuqual/rate_batch_t.hpp"

namespace imuqual::acquire {
namespace {

constexpr double kFullScaleWord = 32767.0;    // 2^15 - 1
constexpr double kStandardGravity = 9.80665;  // m/s^2 per g

int16_t Word(const uint8_t* p) {
  return static_cast<int16_t>(static_cast<uint16_t>(p[0] << 8 | p[1]));
}
uint16_t Unsigned(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }

}  // namespace

Result<std::unique_ptr<CrossbowDecoder>> CrossbowDecoder::Create(const CrossbowOptions& o) {
  auto components = AssignTripleComponents(o.axes, "crossbow");
  if (!components.ok()) return components.status();
  for (bool gyro : {true, false}) {
    const bool used = std::any_of(components->begin(), components->end(),
                                  [&](const AxisComponent& c) { return c.gyro == gyro; });
    const double range = gyro ? o.rate_range_dps : o.g_range;
    if (used && (!(range > 0) || !std::isfinite(range))) {
      return Status::InvalidArgument(gyro ? "crossbow protocol: give rate_range=DEG_PER_S (the "
                                            "model's rate sensor range, e.g. 200)"
                                          : "crossbow protocol: give g_range=G (the model's "
                                            "accelerometer range, e.g. 4)");
    }
  }
  return std::unique_ptr<CrossbowDecoder>(new CrossbowDecoder(o, std::move(*components)));
}

void CrossbowDecoder::Reset() {
  buf_.clear();
  in_sync_ = false;
  have_packet_ = false;
  skipped_since_packet_ = 0;
}

uint8_t CrossbowDecoder::Checksum(const uint8_t* packet, CrossbowChecksum rule) {
  unsigned sum = 0;
  for (size_t k = 1; k + 1 < crossbow::kScaledPacketBytes; ++k) sum += packet[k];
  return static_cast<uint8_t>(rule == CrossbowChecksum::kMod255 ? sum % 255 : sum % 256);
}

void CrossbowDecoder::Feed(const uint8_t* data, size_t size, std::vector<DeviceFrame>* out) {
  constexpr size_t kBytes = crossbow::kScaledPacketBytes;
  buf_.insert(buf_.end(), data, data + size);
  size_t pos = 0;
  auto skip = [&](size_t n) {
    pos += n;
    skipped_since_packet_ += static_cast<int64_t>(n);
    counters_.skipped_bytes += static_cast<int64_t>(n);
  };
  while (pos < buf_.size()) {
    if (buf_[pos] != crossbow::kHeader) {
      in_sync_ = false;
      const void* next = std::memchr(buf_.data() + pos, crossbow::kHeader, buf_.size() - pos);
      skip(next ? static_cast<size_t>(static_cast<const uint8_t*>(next) - (buf_.data() + pos))
                : buf_.size() - pos);
      continue;
    }
    // Out of sync, a header byte and a checksum that holds happen by chance
    // once in 128-256 positions of corrupted data: a packet is taken only
    // when the next one's header follows it.
    if (buf_.size() - pos < (in_sync_ ? kBytes : kBytes + 1)) break;
    const uint8_t* p = buf_.data() + pos;
    const uint8_t sent = p[kBytes - 1];
    const bool ok256 = Checksum(p, CrossbowChecksum::kMod256) == sent;
    const bool ok255 = Checksum(p, CrossbowChecksum::kMod255) == sent;
    const bool ok = options_.checksum == CrossbowChecksum::kMod256   ? ok256
                    : options_.checksum == CrossbowChecksum::kMod255 ? ok255
                                                                     : ok256 || ok255;
    if (!ok || (!in_sync_ && p[kBytes] != crossbow::kHeader)) {
      // The real header may lie inside what looked like this packet.
      if (!ok) ++counters_.bad_checksum;
      in_sync_ = false;
      skip(1);
      continue;
    }
    DeviceFrame f;
    f.values.resize(axes_.size());
    f.flags.assign(axes_.size(), 0);
    for (size_t i = 0; i < axes_.size(); ++i) {
      const AxisComponent& a = axes_[i];
      const int16_t w = Word(p + 1 + 2 * ((a.gyro ? 0 : 3) + a.component));
      const double scaled =
          w * (a.gyro ? options_.rate_range_dps : options_.g_range) * 1.5 / kFullScaleWord;
      f.values[i] = static_cast<float>(a.gyro ? scaled : scaled * kStandardGravity);
      if (w >= 32767 || w <= -32767) f.flags[i] = imuqual::rate_batch_t::FLAG_SATURATED;
    }
    const uint16_t t = Unsigned(p + 13);
    f.temperature_c = static_cast<float>((t * 5.0 / 4096.0 - 1.375) * 44.44);
    // Packets lost since the last good one (no counter to say so): the
    // bytes skipped in between, in packets (a corrupted packet keeps its
    // length; an overrun drops a few bytes of one).
    if (have_packet_ && skipped_since_packet_ > 0) {
      f.rejected_before = std::max<int64_t>(
          1,
          std::llround(static_cast<double>(skipped_since_packet_) / static_cast<double>(kBytes)));
    }
    have_packet_ = true;
    in_sync_ = true;
    skipped_since_packet_ = 0;
    ++counters_.frames;
    out->push_back(std::move(f));
    pos += kBytes;
  }
  buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(pos));
}

}  // namespace imuqual::acquire
