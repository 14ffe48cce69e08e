#include "acquire/crossbow_protocol.h"

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

// 0, 1, 2 for a name ending in x, y, z (either case); -1 otherwise.
int ComponentFromName(const std::string& name) {
  if (name.empty()) return -1;
  switch (name.back()) {
    case 'x':
    case 'X':
      return 0;
    case 'y':
    case 'Y':
      return 1;
    case 'z':
    case 'Z':
      return 2;
    default:
      return -1;
  }
}

}  // namespace

Result<std::unique_ptr<CrossbowDecoder>> CrossbowDecoder::Create(const CrossbowOptions& o) {
  if (o.axes.empty()) return Status::InvalidArgument("crossbow protocol: no axes");
  std::vector<AxisSource> sources(o.axes.size());
  for (bool gyro : {true, false}) {
    std::vector<size_t> of_kind;
    for (size_t i = 0; i < o.axes.size(); ++i) {
      if ((o.axes[i].kind() != pb::ACCEL) == gyro) of_kind.push_back(i);
    }
    if (of_kind.size() > 3) {
      return Status::InvalidArgument(std::string("crossbow protocol: more than 3 ") +
                                     (gyro ? "gyro" : "accelerometer") + " axes");
    }
    if (of_kind.empty()) continue;
    const double range = gyro ? o.rate_range_dps : o.g_range;
    if (!(range > 0) || !std::isfinite(range)) {
      return Status::InvalidArgument(gyro ? "crossbow protocol: give rate_range=DEG_PER_S (the "
                                            "model's rate sensor range, e.g. 200)"
                                          : "crossbow protocol: give g_range=G (the model's "
                                            "accelerometer range, e.g. 4)");
    }
    // By the names' last letter when they are distinct, else in order.
    bool by_name = true;
    int seen = 0;
    for (size_t i : of_kind) {
      const int c = ComponentFromName(o.axes[i].name());
      by_name = by_name && c >= 0 && !(seen >> c & 1);
      if (c >= 0) seen |= 1 << c;
    }
    for (size_t k = 0; k < of_kind.size(); ++k) {
      sources[of_kind[k]].gyro = gyro;
      sources[of_kind[k]].component =
          by_name ? ComponentFromName(o.axes[of_kind[k]].name()) : static_cast<int>(k);
    }
  }
  return std::unique_ptr<CrossbowDecoder>(new CrossbowDecoder(o, std::move(sources)));
}

uint8_t CrossbowDecoder::Checksum(const uint8_t* packet, CrossbowChecksum rule) {
  unsigned sum = 0;
  for (size_t k = 1; k + 1 < crossbow::kScaledPacketBytes; ++k) sum += packet[k];
  return static_cast<uint8_t>(rule == CrossbowChecksum::kMod255 ? sum % 255 : sum % 256);
}

void CrossbowDecoder::Feed(const uint8_t* data, size_t size, std::vector<DeviceFrame>* out) {
  buf_.insert(buf_.end(), data, data + size);
  size_t pos = 0;
  auto skip = [&](size_t n) {
    pos += n;
    counters_.skipped_bytes += static_cast<int64_t>(n);
  };
  while (pos < buf_.size()) {
    if (buf_[pos] != crossbow::kHeader) {
      const void* next = std::memchr(buf_.data() + pos, crossbow::kHeader, buf_.size() - pos);
      skip(next ? static_cast<size_t>(static_cast<const uint8_t*>(next) - (buf_.data() + pos))
                : buf_.size() - pos);
      continue;
    }
    if (buf_.size() - pos < crossbow::kScaledPacketBytes) break;
    const uint8_t* p = buf_.data() + pos;
    const uint8_t sent = p[crossbow::kScaledPacketBytes - 1];
    const bool ok256 = Checksum(p, CrossbowChecksum::kMod256) == sent;
    const bool ok255 = Checksum(p, CrossbowChecksum::kMod255) == sent;
    const bool ok = options_.checksum == CrossbowChecksum::kMod256   ? ok256
                    : options_.checksum == CrossbowChecksum::kMod255 ? ok255
                                                                     : ok256 || ok255;
    if (!ok) {
      // The real header may lie inside what looked like this packet.
      ++counters_.bad_checksum;
      skip(1);
      continue;
    }
    DeviceFrame f;
    f.values.resize(axes_.size());
    f.flags.assign(axes_.size(), 0);
    for (size_t i = 0; i < axes_.size(); ++i) {
      const AxisSource& a = axes_[i];
      const int16_t w = Word(p + 1 + 2 * ((a.gyro ? 0 : 3) + a.component));
      const double scaled =
          w * (a.gyro ? options_.rate_range_dps : options_.g_range) * 1.5 / kFullScaleWord;
      f.values[i] = static_cast<float>(a.gyro ? scaled : scaled * kStandardGravity);
      if (w >= 32767 || w <= -32767) f.flags[i] = imuqual::rate_batch_t::FLAG_SATURATED;
    }
    const uint16_t t = Unsigned(p + 13);
    f.temperature_c = static_cast<float>((t * 5.0 / 4096.0 - 1.375) * 44.44);
    ++counters_.frames;
    out->push_back(std::move(f));
    pos += crossbow::kScaledPacketBytes;
  }
  buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(pos));
}

}  // namespace imuqual::acquire
