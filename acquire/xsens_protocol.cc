#include "acquire/xsens_protocol.h"

#include <cmath>
#include <cstring>
#include <numbers>

#include "imuqual/rate_batch_t.hpp"

namespace imuqual::acquire {
namespace {

uint16_t Be16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }
uint32_t Be32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) << 24 | static_cast<uint32_t>(p[1]) << 16 |
         static_cast<uint32_t>(p[2]) << 8 | p[3];
}

// One value of the given precision at p; its size in bytes (0: unknown).
int ValueSize(int precision) {
  switch (precision) {
    case xsens::kPrecisionFloat32:
      return 4;
    case xsens::kPrecisionFp1220:
      return 4;
    case xsens::kPrecisionFp1632:
      return 6;
    default:
      return 8;
  }
}

double ReadValue(const uint8_t* p, int precision) {
  switch (precision) {
    case xsens::kPrecisionFloat32: {
      const uint32_t bits = Be32(p);
      float f;
      std::memcpy(&f, &bits, sizeof f);
      return f;
    }
    case xsens::kPrecisionFp1220:
      return static_cast<int32_t>(Be32(p)) / 1048576.0;
    case xsens::kPrecisionFp1632: {
      // 32-bit fraction, then the 16-bit signed integer part.
      const int64_t raw = static_cast<int64_t>(static_cast<int16_t>(Be16(p + 4))) * 4294967296LL +
                          static_cast<int64_t>(Be32(p));
      return static_cast<double>(raw) / 4294967296.0;
    }
    default: {
      const uint64_t bits = static_cast<uint64_t>(Be32(p)) << 32 | Be32(p + 4);
      double d;
      std::memcpy(&d, &bits, sizeof d);
      return d;
    }
  }
}

struct Triple {
  bool present = false;
  bool hr = false;
  double v[3] = {0, 0, 0};
};

}  // namespace

Result<std::unique_ptr<XsensDecoder>> XsensDecoder::Create(const std::vector<pb::Axis>& axes) {
  auto components = AssignTripleComponents(axes, "xsens");
  if (!components.ok()) return components.status();
  return std::unique_ptr<XsensDecoder>(new XsensDecoder(std::move(*components)));
}

void XsensDecoder::Reset() { buf_.clear(); }

void XsensDecoder::Feed(const uint8_t* data, size_t size, std::vector<DeviceFrame>* out) {
  buf_.insert(buf_.end(), data, data + size);
  size_t pos = 0;
  auto skip = [&](size_t n) {
    pos += n;
    counters_.skipped_bytes += static_cast<int64_t>(n);
  };
  while (pos < buf_.size()) {
    if (buf_[pos] != xsens::kPreamble) {
      const void* next = std::memchr(buf_.data() + pos, xsens::kPreamble, buf_.size() - pos);
      skip(next ? static_cast<size_t>(static_cast<const uint8_t*>(next) - (buf_.data() + pos))
                : buf_.size() - pos);
      continue;
    }
    const size_t avail = buf_.size() - pos;
    if (avail < 4) break;
    const uint8_t* m = buf_.data() + pos;
    if (m[1] != xsens::kMasterBid) {
      skip(1);
      continue;
    }
    size_t len = m[3];
    size_t header = 4;
    if (len == 0xFF) {
      if (avail < 6) break;
      len = Be16(m + 4);
      header = 6;
      if (len > static_cast<size_t>(xsens::kMaxPayload)) {
        ++counters_.malformed;
        skip(1);
        continue;
      }
    }
    const size_t total = header + len + 1;
    if (avail < total) break;
    uint8_t sum = 0;
    for (size_t k = 1; k < total; ++k) sum = static_cast<uint8_t>(sum + m[k]);
    if (sum != 0) {
      // Resynchronise from the byte after this preamble: the real frame
      // start may be inside what looked like this frame.
      ++counters_.bad_checksum;
      skip(1);
      continue;
    }
    if (m[2] == xsens::kMtData2) {
      if (!Payload(m + header, len, out)) ++counters_.malformed;
    } else {
      ++counters_.other_messages;
    }
    pos += total;
  }
  buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(pos));
}

bool XsensDecoder::Payload(const uint8_t* p, size_t n, std::vector<DeviceFrame>* out) {
  Triple gyr, acc;
  std::optional<uint16_t> counter;
  std::optional<double> temperature;
  uint32_t status = 0;
  size_t k = 0;
  while (k < n) {
    if (n - k < 3) return false;
    const uint16_t xdi = Be16(p + k);
    const size_t size = p[k + 2];
    k += 3;
    if (n - k < size) return false;
    const uint8_t* v = p + k;
    k += size;
    const uint16_t type = xdi & 0xFFF0;
    const int precision = xdi & 0x3;
    if (xdi == xsens::kPacketCounter) {
      if (size != 2) return false;
      counter = Be16(v);
    } else if (xdi == xsens::kStatusWord) {
      if (size != 4) return false;
      status = Be32(v);
    } else if (type == xsens::kTemperature) {
      if (size != static_cast<size_t>(ValueSize(precision))) return false;
      temperature = ReadValue(v, precision);
    } else if (type == xsens::kRateOfTurn || type == xsens::kRateOfTurnHr ||
               type == xsens::kAcceleration || type == xsens::kAccelerationHr) {
      if (size != static_cast<size_t>(3 * ValueSize(precision))) return false;
      const bool hr = type == xsens::kRateOfTurnHr || type == xsens::kAccelerationHr;
      Triple& t = (type == xsens::kRateOfTurn || type == xsens::kRateOfTurnHr) ? gyr : acc;
      if (t.present && t.hr && !hr) continue;  // HR already read
      t.present = true;
      t.hr = hr;
      for (int c = 0; c < 3; ++c) t.v[c] = ReadValue(v + c * ValueSize(precision), precision);
    }
  }
  bool any = false;
  for (const AxisComponent& a : axes_) any |= (a.gyro ? gyr : acc).present;
  if (!any) {
    ++counters_.other_messages;
    return true;
  }
  DeviceFrame f;
  f.values.resize(axes_.size());
  f.flags.assign(axes_.size(), 0);
  for (size_t i = 0; i < axes_.size(); ++i) {
    const AxisComponent& a = axes_[i];
    const Triple& t = a.gyro ? gyr : acc;
    if (!t.present || !std::isfinite(t.v[a.component])) {
      f.values[i] = std::nanf("");
      f.flags[i] = imuqual::rate_batch_t::FLAG_INVALID;
      continue;
    }
    f.values[i] = static_cast<float>(a.gyro ? t.v[a.component] * (180.0 / std::numbers::pi)
                                            : t.v[a.component]);
    const int clip_bit = (a.gyro ? 11 : 8) + a.component;
    if (status >> clip_bit & 1u) f.flags[i] |= imuqual::rate_batch_t::FLAG_SATURATED;
  }
  if (counter) f.counter = *counter;
  if (temperature && std::isfinite(*temperature))
    f.temperature_c = static_cast<float>(*temperature);
  ++counters_.frames;
  out->push_back(std::move(f));
  return true;
}

}  // namespace imuqual::acquire
