// A serial device (a UART, a USB CDC-ACM or FTDI adapter, a pseudo-terminal)
// opened in raw mode with termios: baud, data bits, parity, stop bits and
// flow control as configured. Nothing here knows a protocol.
#ifndef IMUQUAL_ACQUIRE_SERIAL_PORT_H_
#define IMUQUAL_ACQUIRE_SERIAL_PORT_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include "common/status.h"

namespace imuqual::acquire {

enum class Parity { kNone, kEven, kOdd };
enum class FlowControl { kNone, kRtsCts, kXonXoff };

struct SerialPortOptions {
  std::string device;        // e.g. /dev/ttyUSB0, or a stable /dev/serial/by-id/... link
  int baud = 115200;         // one of the standard termios rates, 50..4000000
  int data_bits = 8;         // 5..8
  Parity parity = Parity::kNone;
  int stop_bits = 1;         // 1 or 2
  FlowControl flow = FlowControl::kNone;

  Status Validate() const;
};

// Parses "none|even|odd" and "none|rtscts|xonxoff"; errors name the value.
Result<Parity> ParseParity(const std::string& text);
Result<FlowControl> ParseFlowControl(const std::string& text);

// An open port; closes on destruction. Not thread-safe.
class SerialPort {
 public:
  // Opens and configures the device. Errors name the device and the reason
  // (absent, permission, not a terminal, rate not supported).
  static Result<SerialPort> Open(const SerialPortOptions& options);

  SerialPort(SerialPort&& other) noexcept;
  SerialPort& operator=(SerialPort&& other) noexcept;
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;
  ~SerialPort();

  // Waits up to timeout_ms for bytes and reads what is there (at most
  // `capacity`). Returns the count, 0 on timeout; kUnavailable when the
  // device went away (unplugged, hung up), other errors otherwise.
  Result<size_t> Read(uint8_t* buffer, size_t capacity, int timeout_ms);
  // Writes all of `data` (used to configure a device); kUnavailable when the
  // device went away.
  Status Write(const uint8_t* data, size_t size);

  int fd() const { return fd_; }

 private:
  explicit SerialPort(int fd, std::string device) : fd_(fd), device_(std::move(device)) {}
  int fd_ = -1;
  std::string device_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_SERIAL_PORT_H_
