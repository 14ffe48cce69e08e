#include "acquire/serial_port.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace imuqual::acquire {
namespace {

struct BaudCode {
  int baud;
  speed_t code;
};

constexpr BaudCode kBauds[] = {
    {50, B50},           {75, B75},           {110, B110},         {134, B134},
    {150, B150},         {200, B200},         {300, B300},         {600, B600},
    {1200, B1200},       {1800, B1800},       {2400, B2400},       {4800, B4800},
    {9600, B9600},       {19200, B19200},     {38400, B38400},     {57600, B57600},
    {115200, B115200},   {230400, B230400},   {460800, B460800},   {500000, B500000},
    {576000, B576000},   {921600, B921600},   {1000000, B1000000}, {1152000, B1152000},
    {1500000, B1500000}, {2000000, B2000000}, {2500000, B2500000}, {3000000, B3000000},
    {3500000, B3500000}, {4000000, B4000000},
};

bool BaudToCode(int baud, speed_t* code) {
  for (const BaudCode& b : kBauds) {
    if (b.baud == baud) {
      *code = b.code;
      return true;
    }
  }
  return false;
}

std::string Errno(int e) { return std::strerror(e); }

// The device went away rather than failed: a USB adapter unplugged, a pty
// whose other side closed.
bool IsGone(int e) { return e == EIO || e == ENODEV || e == ENXIO || e == EBADF || e == ENOENT; }

}  // namespace

Status SerialPortOptions::Validate() const {
  if (device.empty()) return Status::InvalidArgument("serial: device path is empty");
  speed_t code;
  if (!BaudToCode(baud, &code)) {
    return Status::InvalidArgument("serial " + device + ": baud " + std::to_string(baud) +
                                   " is not a standard rate (9600, 115200, 460800, 921600, ...)");
  }
  if (data_bits < 5 || data_bits > 8) {
    return Status::InvalidArgument("serial " + device + ": data bits must be 5..8");
  }
  if (stop_bits != 1 && stop_bits != 2) {
    return Status::InvalidArgument("serial " + device + ": stop bits must be 1 or 2");
  }
  return Status::Ok();
}

Result<Parity> ParseParity(const std::string& text) {
  if (text == "none" || text == "n") return Parity::kNone;
  if (text == "even" || text == "e") return Parity::kEven;
  if (text == "odd" || text == "o") return Parity::kOdd;
  return Status::InvalidArgument("parity '" + text + "' must be none, even or odd");
}

Result<FlowControl> ParseFlowControl(const std::string& text) {
  if (text == "none") return FlowControl::kNone;
  if (text == "rtscts") return FlowControl::kRtsCts;
  if (text == "xonxoff") return FlowControl::kXonXoff;
  return Status::InvalidArgument("flow control '" + text + "' must be none, rtscts or xonxoff");
}

Result<SerialPort> SerialPort::Open(const SerialPortOptions& o) {
  IMUQUAL_RETURN_IF_ERROR(o.Validate());
  const int fd = ::open(o.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    const std::string why = "serial " + o.device + ": cannot open: " + Errno(e);
    return e == ENOENT || e == ENODEV || e == ENXIO || e == EIO ? Status::Unavailable(why)
                                                                 : Status::IoError(why);
  }
  SerialPort port(fd, o.device);
  if (!::isatty(fd)) return Status::InvalidArgument("serial " + o.device + ": not a terminal device");
  // One reader per device: a second station on the same unit would steal
  // bytes from the first.
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    return Status::Unavailable("serial " + o.device + ": in use by another process");
  }
  // And no later open() but root's (terminal programs ignore flock).
  (void)::ioctl(fd, TIOCEXCL);
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) {
    return Status::IoError("serial " + o.device + ": tcgetattr: " + Errno(errno));
  }
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
  static constexpr tcflag_t kSize[] = {CS5, CS6, CS7, CS8};
  tio.c_cflag |= kSize[o.data_bits - 5];
  tio.c_iflag &= ~static_cast<tcflag_t>(INPCK | ISTRIP | IXON | IXOFF | IXANY);
  if (o.parity != Parity::kNone) {
    tio.c_cflag |= PARENB;
    if (o.parity == Parity::kOdd) tio.c_cflag |= PARODD;
    tio.c_iflag |= INPCK;
  }
  if (o.stop_bits == 2) tio.c_cflag |= CSTOPB;
  if (o.flow == FlowControl::kRtsCts) tio.c_cflag |= CRTSCTS;
  // Keep DTR up across close and reopen: dropping it resets many fixtures.
  tio.c_cflag &= ~static_cast<tcflag_t>(HUPCL);
  if (o.flow == FlowControl::kXonXoff) tio.c_iflag |= IXON | IXOFF;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  speed_t code = B0;
  BaudToCode(o.baud, &code);
  if (::cfsetispeed(&tio, code) != 0 || ::cfsetospeed(&tio, code) != 0 ||
      ::tcsetattr(fd, TCSANOW, &tio) != 0) {
    return Status::InvalidArgument("serial " + o.device + ": cannot set " + std::to_string(o.baud) +
                                   " baud: " + Errno(errno));
  }
  // Drivers may ignore what they cannot do (a rate, 7 data bits, parity,
  // RTS/CTS): read the settings back rather than trust them.
  termios check{};
  if (::tcgetattr(fd, &check) == 0) {
    if (::cfgetispeed(&check) != code) {
      return Status::InvalidArgument("serial " + o.device + ": the driver refused " +
                                     std::to_string(o.baud) + " baud");
    }
    const tcflag_t line_bits = CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS;
    if ((check.c_cflag & line_bits) != (tio.c_cflag & line_bits)) {
      return Status::InvalidArgument("serial " + o.device +
                                     ": the driver refused the data bits, parity, stop bits or "
                                     "flow control asked for");
    }
  }
  // Bytes queued before we opened belong to nobody's run.
  (void)::tcflush(fd, TCIFLUSH);
  return port;
}

SerialPort::SerialPort(SerialPort&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), device_(std::move(other.device_)) {}

namespace {
void Close(int fd) {
  if (fd < 0) return;
  (void)::ioctl(fd, TIOCNXCL);  // the exclusive mode must not outlive us
  ::close(fd);
}
}  // namespace

SerialPort& SerialPort::operator=(SerialPort&& other) noexcept {
  if (this != &other) {
    Close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    device_ = std::move(other.device_);
  }
  return *this;
}

SerialPort::~SerialPort() { Close(fd_); }

Result<size_t> SerialPort::Read(uint8_t* buffer, size_t capacity, int timeout_ms) {
  pollfd p{fd_, POLLIN, 0};
  const int r = ::poll(&p, 1, timeout_ms);
  if (r < 0) {
    if (errno == EINTR) return size_t{0};
    return Status::IoError("serial " + device_ + ": poll: " + Errno(errno));
  }
  if (r == 0) return size_t{0};
  if (p.revents & POLLNVAL) return Status::Unavailable("serial " + device_ + ": closed");
  const ssize_t n = ::read(fd_, buffer, capacity);
  if (n > 0) return static_cast<size_t>(n);
  if (n == 0) return Status::Unavailable("serial " + device_ + ": hung up");
  const int e = errno;
  if (e == EAGAIN || e == EINTR) return size_t{0};
  if (IsGone(e)) return Status::Unavailable("serial " + device_ + ": " + Errno(e));
  return Status::IoError("serial " + device_ + ": read: " + Errno(e));
}

Status SerialPort::Write(const uint8_t* data, size_t size) {
  size_t done = 0;
  while (done < size) {
    const ssize_t n = ::write(fd_, data + done, size - done);
    if (n > 0) {
      done += static_cast<size_t>(n);
      continue;
    }
    const int e = errno;
    if (n < 0 && (e == EAGAIN || e == EINTR)) {
      pollfd p{fd_, POLLOUT, 0};
      if (::poll(&p, 1, 1000) <= 0) return Status::IoError("serial " + device_ + ": write timed out");
      continue;
    }
    if (IsGone(e)) return Status::Unavailable("serial " + device_ + ": " + Errno(e));
    return Status::IoError("serial " + device_ + ": write: " + Errno(e));
  }
  return Status::Ok();
}

}  // namespace imuqual::acquire
