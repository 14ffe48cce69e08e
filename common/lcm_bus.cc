#include "common/lcm_bus.h"

#include <poll.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "common/crc32c.h"
#include "common/log.h"

namespace imuqual {

std::string BusAddress::ToUrl() const {
  return "udpm://" + group + ":" + std::to_string(port) + "?ttl=" + std::to_string(ttl) +
         "&recv_buf_size=" + std::to_string(recv_buf_bytes);
}

int BusTtl(const std::string& url) {
  for (size_t at = url.find("ttl="); at != std::string::npos; at = url.find("ttl=", at + 1)) {
    if (at > 0 && (url[at - 1] == '?' || url[at - 1] == '&')) return std::atoi(url.c_str() + at + 4);
  }
  return 0;
}

LcmBus::LcmBus(std::string url, const BusSecurity& security)
    : url_(std::move(url)),
      security_description_(security.Describe(BusTtl(url_) > 0)),
      sealer_(std::make_unique<BusSealer>(security)),
      opener_(security) {}
LcmBus::~LcmBus() = default;

Result<std::unique_ptr<LcmBus>> LcmBus::Open(const std::string& url, BusSecurity security) {
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
  IMUQUAL_RETURN_IF_ERROR(CheckSecurity(url, security));
  std::unique_ptr<LcmBus> bus(new LcmBus(effective, security));
  bus->lcm_ = std::make_unique<lcm::LCM>(effective);
  if (!bus->lcm_->good()) {
    return Status::Unavailable("cannot open LCM bus '" + url +
                               "' (is multicast routed on this interface?)");
  }
  return bus;
}

Status LcmBus::CheckSecurity(const std::string& url, const BusSecurity& security) {
  // A listener holding the roles' public keys takes signed messages only: it
  // needs no station key anywhere.
  const bool signed_listener = security.role == BusRole::kMonitor && !security.trusted.empty();
  if (url.rfind("udpm://", 0) == 0 && BusTtl(url) > 0 && !security.station_key &&
      !security.insecure_bus && !signed_listener) {
    return Status::InvalidArgument("the bus " + url +
                                   " reaches beyond this host (ttl > 0): give the station key "
                                   "(--key-file; make one with imuqual keygen), or say "
                                   "--insecure-bus to run unauthenticated (every run records it)");
  }
  return Status::Ok();
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
    ++dispatch_;  // handle() dispatches one message to every matching subscription
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

Status LcmBus::PublishBytes(const std::string& channel, std::vector<uint8_t> bytes) {
  sealer_->Seal(channel, &bytes);
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

const BusOpener::Opened* LcmBus::Unseal(const lcm_recv_buf_t* rbuf, const char* channel) {
  if (opened_dispatch_ != dispatch_) {
    opened_ = opener_.Open(channel, static_cast<const uint8_t*>(rbuf->data), rbuf->data_size,
                           rbuf->recv_utime);
    opened_dispatch_ = dispatch_;
    int kind = -1;
    switch (opened_.verdict) {
      case BusOpener::Verdict::kOk: break;
      case BusOpener::Verdict::kDamaged: ++damaged_; kind = 0; break;
      case BusOpener::Verdict::kUnauthenticated: ++unauthenticated_; kind = 1; break;
      case BusOpener::Verdict::kReplayed: ++replayed_; kind = 2; break;
    }
    if (kind >= 0) {
      static constexpr const char* kWhat[] = {"a damaged", "an unauthenticated", "a replayed"};
      static constexpr const char* kCounted[] = {"damaged", "unauthenticated", "replayed"};
      std::lock_guard<std::mutex> lock(warned_mu_);
      if (refused_channels_[kind].insert(channel).second) {
        std::string from;
        if (opened_.origin.instance != 0) {
          from = " (says it is from " + std::string(RoleName(opened_.origin.role)) + ")";
        }
        LogWarning(std::string("dropped ") + kWhat[kind] + " message on " + channel + from + ": " +
                   opened_.why + " (further " + kCounted[kind] +
                   " messages on this channel are counted, not logged)");
      }
    }
  }
  return opened_.verdict == BusOpener::Verdict::kOk ? &opened_ : nullptr;
}

void LcmBus::NoteHandlerError(const std::string& channel, const std::string& what) {
  ++handler_errors_;
  LogError("handler for " + channel + " failed: " + what);
}

}  // namespace imuqual
