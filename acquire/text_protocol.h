// A text-line protocol: one sample per line, fields separated by a
// delimiter, in a configured column order (many MEMS evaluation boards and
// in-house test fixtures print this). Optionally NMEA-style framing,
// "$fields*HH" with HH the XOR of the bytes between '$' and '*', for links
// that need a checksum. Lines are ended by "\n" (a "\r" before it is
// dropped); lines starting with '#' are device chatter and are skipped.
#ifndef IMUQUAL_ACQUIRE_TEXT_PROTOCOL_H_
#define IMUQUAL_ACQUIRE_TEXT_PROTOCOL_H_

#include <memory>
#include <string>
#include <vector>

#include "acquire/device_protocol.h"
#include "common/status.h"

namespace imuqual::acquire {

struct TextProtocolOptions {
  std::vector<std::string> columns;  // field names in line order; "_" ignores a field
  char delimiter = ',';              // ' ' means any run of spaces and tabs
  std::vector<std::string> axes;     // the axes' columns, in output order
  std::vector<double> scales;        // per axis: value = field * scale (empty: all 1)
  std::string counter_column;        // the device sample counter ("" = none)
  int counter_bits = 0;              // the counter wraps at 2^bits (0: it does not wrap)
  std::string temperature_column;    // deg C ("" = none)
  bool nmea_checksum = false;        // lines are "$...*HH"
  size_t max_line = 4096;            // longer lines are malformed
};

class TextLineDecoder : public FrameDecoder {
 public:
  // Errors name the option that is wrong (an axis not among the columns...).
  static Result<std::unique_ptr<TextLineDecoder>> Create(TextProtocolOptions options);

  void Feed(const uint8_t* data, size_t size, std::vector<DeviceFrame>* out) override;
  void Reset() override;
  int counter_bits() const override;

 private:
  explicit TextLineDecoder(TextProtocolOptions options) : o_(std::move(options)) {}
  void Line(std::string_view line, std::vector<DeviceFrame>* out);

  TextProtocolOptions o_;
  std::vector<int> axis_field_;   // field index of each axis
  int counter_field_ = -1;
  int temperature_field_ = -1;
  std::string line_;
  bool synced_ = false;           // false: the bytes so far may start mid-line
  bool overlong_ = false;         // dropping the rest of a too-long line
  int64_t rejected_ = 0;          // lines rejected since the last good one
  std::vector<std::string_view> fields_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_TEXT_PROTOCOL_H_
