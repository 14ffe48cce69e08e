#include "common/lcm_bus.h"

#include <poll.h>

#include <cerrno>
#include <cstring>

#include "common/crc32c.h"
#include "common/log.h"

namespace imuqual {

std::string BusAddress::ToUrl() const {
  return "udpm://" + group + ":" + std::to_string(port) + "?ttl=" + std::to_string(ttl) +
         "&recv_buf_size=" + std::to_string(recv_buf_bytes);
}

LcmBus::LcmBus(std::string url) : url_(std::move(url)) {}
LcmBus::~LcmBus() = default;

Result<std::unique_ptr<LcmBus>> LcmBus::Open(const std::string& url) {
  if (url.rfind("udpm://", 0) != 0 && url.rfind("file://", 0) != 0 &&
      url.rfind("memq://", 0) != 0) {
    return Status::InvalidArgument("LCM URL must start with udpm://, file:// or memq://: '" + url +
                                   "'");
  }
  // The kernel receive buffer is sized on purpose: LCM's default leaves it at
  // the system default (~200 KB), which a burst of resends overflows.
  std::string effective = url;
  if (url.rfind("udpm://", 0) == 0 && url.find("recv_buf_size=") == std::string::npos) {
    effective += (url.find('?') == std::string::npos ? "?" : "&");
    effective += "recv_buf_size=" + std::to_string(BusAddress{}.recv_buf_bytes);
  }
  std::unique_ptr<LcmBus> bus(new LcmBus(effective));
  bus->lcm_ = std::make_unique<lcm::LCM>(effective);
  if (!bus->lcm_->good()) {
    return Status::Unavailable("cannot open LCM bus '" + url +
                               "' (is multicast routed on this interface?)");
  }
  return bus;
}

Status LcmBus::HandleFor(int timeout_ms) {
  int fd = lcm_->getFileno();
  if (fd < 0) return Status::Unavailable("LCM bus has no receive socket: " + url_);
  // Wait up to timeout_ms for the first message, then dispatch whatever is
  // already queued (bounded, so a flood cannot starve the caller's loop).
  constexpr int kMaxDispatchPerCall = 2000;
  for (int dispatched = 0; dispatched < kMaxDispatchPerCall; ++dispatched) {
    pollfd pfd{fd, POLLIN, 0};
    const int rc = ::poll(&pfd, 1, dispatched == 0 ? timeout_ms : 0);
    if (rc < 0) {
      if (errno == EINTR) return Status::Ok();
      return Status::IoError(std::string("poll on LCM bus: ") + std::strerror(errno));
    }
    if (rc == 0) return Status::Ok();
    if (lcm_->handle() != 0) return Status::IoError("LCM handle() failed on " + url_);
  }
  return Status::Ok();
}

void LcmBus::DispatchRaw(const lcm_recv_buf_t* rbuf, const char* channel, void* user) {
  static_cast<RawSubscription*>(user)->fn(rbuf, channel);
}

void LcmBus::SubscribeRaw(const std::string& channel_regex, int queue_capacity,
                          std::unique_ptr<RawSubscription> sub) {
  lcm_subscription_t* s =
      lcm_subscribe(lcm_->getUnderlyingLCM(), channel_regex.c_str(), &DispatchRaw, sub.get());
  if (s != nullptr) lcm_subscription_set_queue_capacity(s, queue_capacity);
  subscriptions_.push_back(std::move(sub));
}

uint32_t MessageSeal(const std::string& channel, const void* data, size_t size) {
  return Crc32cExtend(Crc32c(channel.c_str(), channel.size() + 1), data, size);
}

void AppendSeal(const std::string& channel, std::vector<uint8_t>* bytes) {
  const uint32_t seal = MessageSeal(channel, bytes->data(), bytes->size());
  for (int shift = 24; shift >= 0; shift -= 8) bytes->push_back(static_cast<uint8_t>(seal >> shift));
}

Status LcmBus::PublishBytes(const std::string& channel, std::vector<uint8_t> bytes) {
  AppendSeal(channel, &bytes);
  if (lcm_->publish(channel, bytes.data(), static_cast<unsigned>(bytes.size())) != 0) {
    ++publish_errors_;
    return Status::IoError("LCM publish failed on channel " + channel);
  }
  return Status::Ok();
}

void LcmBus::NoteDecodeError(const std::string& channel, const std::string& type_name,
                             const char* why) {
  ++decode_errors_;
  std::lock_guard<std::mutex> lock(warned_mu_);
  if (warned_channels_.insert(channel).second) {
    LogWarning("rejected a message on " + channel + " (expected " + type_name + "): " + why +
               " (further rejections on this channel are counted, not logged)");
  }
}

bool LcmBus::Unseal(const lcm_recv_buf_t* rbuf, const char* channel) {
  const char* why = nullptr;
  if (rbuf->data_size < kSealBytes) {
    why = "shorter than its seal";
  } else {
    const auto* bytes = static_cast<const uint8_t*>(rbuf->data);
    const size_t size = rbuf->data_size - kSealBytes;
    uint32_t sent = 0;
    for (size_t i = 0; i < kSealBytes; ++i) sent = (sent << 8) | bytes[size + i];
    if (sent == MessageSeal(channel, bytes, size)) return true;
    why = "its CRC-32C seal does not match (damaged in flight, or not sealed by this station)";
  }
  ++damaged_;
  std::lock_guard<std::mutex> lock(warned_mu_);
  if (damaged_channels_.insert(channel).second) {
    LogWarning(std::string("dropped a damaged message on ") + channel + ": " + why +
               " (further damaged messages on this channel are counted, not logged)");
  }
  return false;
}

void LcmBus::NoteHandlerError(const std::string& channel, const std::string& what) {
  ++handler_errors_;
  LogError("handler for " + channel + " failed: " + what);
}

}  // namespace imuqual
