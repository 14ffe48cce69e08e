// A stand-in serial device for tests: a pseudo-terminal whose slave side is
// reached through a stable symlink (as /dev/serial/by-id/... links are), so
// the device can be "unplugged" (master closed, link removed) and plugged
// back in (a new pty behind the same link) while a source reads it.
#ifndef IMUQUAL_TESTS_PTY_DEVICE_H_
#define IMUQUAL_TESTS_PTY_DEVICE_H_

#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace imuqual::testing {

class PtyDevice {
 public:
  // `link`: the path the source opens.
  explicit PtyDevice(std::string link) : link_(std::move(link)) { Plug(); }
  ~PtyDevice() { Unplug(); }
  PtyDevice(const PtyDevice&) = delete;
  PtyDevice& operator=(const PtyDevice&) = delete;

  const std::string& path() const { return link_; }
  bool plugged() const { return master_ >= 0; }

  void Plug() {
    if (master_ >= 0) return;
    master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
    if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0) {
      throw std::runtime_error("cannot create a pseudo-terminal");
    }
    // Raw from the start: bytes written before the reader configures the
    // line must not be echoed or edited.
    termios tio{};
    ::tcgetattr(master_, &tio);
    ::cfmakeraw(&tio);
    ::tcsetattr(master_, TCSANOW, &tio);
    std::error_code ignored;
    std::filesystem::remove(link_, ignored);
    std::filesystem::create_symlink(::ptsname(master_), link_);
  }

  // The cable is pulled: the reader's next read fails, the path is gone.
  void Unplug() {
    if (master_ < 0) return;
    std::error_code ignored;
    std::filesystem::remove(link_, ignored);
    ::close(master_);
    master_ = -1;
  }

  // Writes all of `data`, waiting while the reader has not drained the
  // line (as a device under hardware flow control would), until `stop` is
  // set or 60 s pass; false if not all was written.
  bool Write(const uint8_t* data, size_t size, const std::atomic<bool>* stop = nullptr) {
    size_t done = 0;
    int waits = 0;
    while (master_ >= 0 && done < size) {
      const ssize_t n = ::write(master_, data + done, size - done);
      if (n > 0) {
        done += static_cast<size_t>(n);
        waits = 0;
      } else if (n < 0 && errno != EINTR && errno != EAGAIN) {
        return false;
      } else {
        if (++waits > 6000 || (stop && *stop)) return false;
        pollfd p{master_, POLLOUT, 0};
        ::poll(&p, 1, 10);
      }
    }
    return master_ >= 0;
  }
  bool Write(const std::string& s, const std::atomic<bool>* stop = nullptr) {
    return Write(reinterpret_cast<const uint8_t*>(s.data()), s.size(), stop);
  }

 private:
  std::string link_;
  int master_ = -1;
};

}  // namespace imuqual::testing

#endif  // IMUQUAL_TESTS_PTY_DEVICE_H_
