#include "acquire/text_protocol.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <set>
#include <string_view>

#include "imuqual/rate_batch_t.hpp"

namespace imuqual::acquire {
namespace {

int FieldIndex(const std::vector<std::string>& columns, const std::string& name) {
  for (size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return static_cast<int>(i);
  }
  return -1;
}

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// A whole field as a double ("nan" allowed); false if it is not a number.
bool ParseDouble(std::string_view field, double* out) {
  while (!field.empty() && (field.front() == ' ' || field.front() == '\t')) field.remove_prefix(1);
  while (!field.empty() && (field.back() == ' ' || field.back() == '\t')) field.remove_suffix(1);
  if (field.empty() || field.size() > 64) return false;
  char buf[65];
  field.copy(buf, field.size());
  buf[field.size()] = '\0';
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(buf, &end);
  if (*end != '\0' || errno == ERANGE || std::isinf(v)) return false;
  *out = v;
  return true;
}

bool ParseCounter(std::string_view field, uint64_t* out) {
  while (!field.empty() && field.front() == ' ') field.remove_prefix(1);
  while (!field.empty() && field.back() == ' ') field.remove_suffix(1);
  if (field.empty() || field.size() > 20) return false;
  uint64_t v = 0;
  for (char c : field) {
    if (c < '0' || c > '9') return false;
    const uint64_t digit = static_cast<uint64_t>(c - '0');
    if (v > (std::numeric_limits<uint64_t>::max() - digit) / 10) return false;
    v = v * 10 + digit;
  }
  *out = v;
  return true;
}

}  // namespace

Result<std::unique_ptr<TextLineDecoder>> TextLineDecoder::Create(TextProtocolOptions o) {
  if (o.columns.empty()) {
    return Status::InvalidArgument("text protocol: name the fields of a line (columns=count/gx/gy/gz)");
  }
  std::set<std::string> seen;
  for (const std::string& c : o.columns) {
    if (c.empty()) return Status::InvalidArgument("text protocol: an empty column name (use _ to skip a field)");
    if (c != "_" && !seen.insert(c).second) {
      return Status::InvalidArgument("text protocol: column '" + c + "' named twice");
    }
  }
  if (o.axes.empty()) return Status::InvalidArgument("text protocol: no axes");
  if (!o.scales.empty() && o.scales.size() != o.axes.size()) {
    return Status::InvalidArgument("text protocol: one scale per axis");
  }
  if (o.scales.empty()) o.scales.assign(o.axes.size(), 1.0);
  for (double s : o.scales) {
    if (!std::isfinite(s) || s == 0) return Status::InvalidArgument("text protocol: scale must be finite and non-zero");
  }
  if (o.counter_bits < 0 || o.counter_bits > 63) {
    return Status::InvalidArgument("text protocol: counter_bits must be 0..63");
  }
  if (o.delimiter == '\n' || o.delimiter == '\r' || o.delimiter == '\0') {
    return Status::InvalidArgument("text protocol: the delimiter cannot be a line end");
  }
  std::unique_ptr<TextLineDecoder> d(new TextLineDecoder(o));
  for (const std::string& axis : d->o_.axes) {
    const int f = FieldIndex(d->o_.columns, axis);
    if (f < 0) return Status::InvalidArgument("text protocol: axis '" + axis + "' is not one of the columns");
    d->axis_field_.push_back(f);
  }
  if (!d->o_.counter_column.empty()) {
    d->counter_field_ = FieldIndex(d->o_.columns, d->o_.counter_column);
    if (d->counter_field_ < 0) {
      return Status::InvalidArgument("text protocol: counter '" + d->o_.counter_column +
                                     "' is not one of the columns");
    }
  }
  if (!d->o_.temperature_column.empty()) {
    d->temperature_field_ = FieldIndex(d->o_.columns, d->o_.temperature_column);
    if (d->temperature_field_ < 0) {
      return Status::InvalidArgument("text protocol: temperature '" + d->o_.temperature_column +
                                     "' is not one of the columns");
    }
  }
  return d;
}

int TextLineDecoder::counter_bits() const {
  if (counter_field_ < 0) return 0;
  return o_.counter_bits == 0 ? 64 : o_.counter_bits;
}

void TextLineDecoder::Reset() {
  rejected_ = 0;
  line_.clear();
  synced_ = false;
  overlong_ = false;
}

void TextLineDecoder::Feed(const uint8_t* data, size_t size, std::vector<DeviceFrame>* out) {
  for (size_t i = 0; i < size; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == '\n') {
      if (!synced_) {
        counters_.skipped_bytes += static_cast<int64_t>(line_.size()) + 1;
        synced_ = true;
      } else if (overlong_) {
        ++counters_.malformed;
        ++rejected_;
      } else {
        std::string_view line(line_);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        Line(line, out);
      }
      line_.clear();
      overlong_ = false;
      continue;
    }
    if (overlong_) continue;
    line_.push_back(c);
    if (line_.size() > o_.max_line) {
      if (!synced_) counters_.skipped_bytes += static_cast<int64_t>(line_.size());
      line_.clear();
      overlong_ = synced_;
    }
  }
}

void TextLineDecoder::Line(std::string_view line, std::vector<DeviceFrame>* out) {
  if (line.empty()) return;
  if (line.front() == '#') {
    ++counters_.other_messages;
    return;
  }
  if (o_.nmea_checksum) {
    const size_t star = line.rfind('*');
    if (line.front() != '$' || star == std::string_view::npos || star + 3 != line.size()) {
      ++counters_.malformed;
      ++rejected_;
      return;
    }
    const int hi = HexDigit(line[star + 1]), lo = HexDigit(line[star + 2]);
    uint8_t sum = 0;
    for (size_t k = 1; k < star; ++k) sum ^= static_cast<uint8_t>(line[k]);
    if (hi < 0 || lo < 0 || sum != hi * 16 + lo) {
      ++counters_.bad_checksum;
      ++rejected_;
      return;
    }
    line = line.substr(1, star - 1);
  }
  fields_.clear();
  if (o_.delimiter == ' ') {
    size_t k = 0;
    while (k < line.size()) {
      while (k < line.size() && (line[k] == ' ' || line[k] == '\t')) ++k;
      if (k == line.size()) break;
      size_t e = k;
      while (e < line.size() && line[e] != ' ' && line[e] != '\t') ++e;
      fields_.push_back(line.substr(k, e - k));
      k = e;
    }
  } else {
    size_t k = 0;
    for (;;) {
      const size_t e = line.find(o_.delimiter, k);
      fields_.push_back(line.substr(k, e == std::string_view::npos ? std::string_view::npos : e - k));
      if (e == std::string_view::npos) break;
      k = e + 1;
    }
  }
  if (fields_.size() != o_.columns.size()) {
    ++counters_.malformed;
    ++rejected_;
    return;
  }
  DeviceFrame f;
  f.values.resize(axis_field_.size());
  f.flags.assign(axis_field_.size(), 0);
  for (size_t a = 0; a < axis_field_.size(); ++a) {
    double v;
    if (!ParseDouble(fields_[axis_field_[a]], &v)) {
      ++counters_.malformed;
      ++rejected_;
      return;
    }
    f.values[a] = static_cast<float>(v * o_.scales[a]);
    // NaN on the line, or a value beyond float32 after scaling: no sample.
    if (!std::isfinite(f.values[a])) f.flags[a] |= imuqual::rate_batch_t::FLAG_INVALID;
  }
  if (counter_field_ >= 0) {
    uint64_t c;
    if (!ParseCounter(fields_[counter_field_], &c) ||
        (o_.counter_bits > 0 && c >> o_.counter_bits != 0)) {
      ++counters_.malformed;
      ++rejected_;
      return;
    }
    f.counter = c;
  }
  if (temperature_field_ >= 0) {
    double t;
    if (ParseDouble(fields_[temperature_field_], &t) && std::isfinite(t)) f.temperature_c = static_cast<float>(t);
  }
  f.rejected_before = rejected_;
  rejected_ = 0;
  ++counters_.frames;
  out->push_back(std::move(f));
}

}  // namespace imuqual::acquire
