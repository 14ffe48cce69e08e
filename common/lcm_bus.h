// LcmBus: one LCM instance with typed, checked publish/subscribe (after
// Drake's DrakeLcm). Every message on the wire is sealed (common/bus_seal.h):
// its LCM encoding is followed by a trailer naming the sender's role,
// instance and counter and the time it was sent, a CRC-32C, and, with a
// station key, a MAC (keyed BLAKE2b) and, where the roles' public keys are
// known, the sender role's Ed25519 signature on the verdict-bearing
// channels. A message reaches a handler only if its seal holds, its sender
// may say it and it is fresh, and it decodes completely as the subscribed
// type (right fingerprint, every byte accounted for). A refused message is
// counted by kind: damaged (its CRC fails: a bit flipped in flight, a lost
// message to the protocol, which repairs it like any other), unauthenticated
// (no or a wrong MAC, a role that may not publish there, a missing or wrong
// signature), replayed (seen before, or older than the freshness window), or
// a decode error; each kind is logged once per channel. No exception escapes
// an LCM handler: a handler that throws is counted as a handler error.
//
// Threading: Publish() may be called from any thread (LCM serializes sends).
// Subscribe() and HandleFor() must be called from one thread, the bus thread;
// handlers run on it and must only copy and enqueue.
#ifndef IMUQUAL_COMMON_LCM_BUS_H_
#define IMUQUAL_COMMON_LCM_BUS_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/bus_seal.h"
#include "common/status.h"

namespace imuqual {

// A station bus URL: multicast group and port, TTL and kernel receive buffer.
struct BusAddress {
  std::string group = "239.255.76.67";
  int port = 7667;
  int ttl = 0;                          // 0: never leaves this host
  int recv_buf_bytes = 4 * 1024 * 1024; // SO_RCVBUF request (capped by net.core.rmem_max)
  std::string ToUrl() const;
};

// The ttl a bus URL asks for (0 when a udpm URL says nothing: LCM's
// default, this host only).
int BusTtl(const std::string& url);

class LcmBus {
 public:
  // Connects to `url` (e.g. "udpm://239.255.76.67:7701?ttl=0") as
  // `security` says (role, keys, choices); a udpm URL without
  // recv_buf_size gets BusAddress's default. Fails with a clear error if LCM
  // cannot open it, or if the bus reaches beyond this host (ttl > 0) without
  // a station key and without security.insecure_bus.
  static Result<std::unique_ptr<LcmBus>> Open(const std::string& url, BusSecurity security);
  // Ok, or why `security` may not open `url`: a bus beyond this host (ttl >
  // 0) without a station key, unless security.insecure_bus.
  static Status CheckSecurity(const std::string& url, const BusSecurity& security);
  // The same as a tool without keys (tests, scripts on one host).
  static Result<std::unique_ptr<LcmBus>> Open(const std::string& url) {
    return Open(url, BusSecurity{});
  }
  ~LcmBus();
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  // Subscribes to channels matching `channel_regex` (anchored by LCM).
  // `queue_capacity` is the number of messages LCM keeps for this
  // subscription between HandleFor() calls; beyond it LCM drops silently, so
  // size it to what can be in flight. `handler(channel, msg, recv_utime)`.
  template <typename T>
  void Subscribe(const std::string& channel_regex, int queue_capacity,
                 std::function<void(const std::string&, T&&, int64_t)> handler) {
    Subscribe<T>(channel_regex, queue_capacity, nullptr, std::move(handler));
  }
  // The same, but a message whose channel `accept` refuses is dropped before
  // it is decoded (e.g. an analyze shard skipping other shards' units).
  template <typename T>
  void Subscribe(const std::string& channel_regex, int queue_capacity,
                 std::function<bool(const char* channel)> accept,
                 std::function<void(const std::string&, T&&, int64_t)> handler) {
    SubscribeWithOrigin<T>(channel_regex, queue_capacity, std::move(accept),
                           [handler = std::move(handler)](const std::string& channel, T&& msg,
                                                          const MessageOrigin& origin) {
                             handler(channel, std::move(msg), origin.recv_utime);
                           });
  }
  // The same, with what the seal says of the sender (role, instance, ...).
  template <typename T>
  void SubscribeWithOrigin(
      const std::string& channel_regex, int queue_capacity, std::function<bool(const char* channel)> accept,
      std::function<void(const std::string&, T&&, const MessageOrigin&)> handler);

  // Encodes and publishes. Fails if encoding or sending fails.
  template <typename T>
  Status Publish(const std::string& channel, const T& msg);

  // Publishes an already encoded message (e.g. a retained batch resent); the
  // seal is added here.
  Status PublishEncoded(const std::string& channel, const std::vector<uint8_t>& bytes) {
    return PublishBytes(channel, bytes);
  }

  // Waits up to `timeout_ms` for a message, then dispatches what is queued
  // (at most a few thousand messages per call).
  Status HandleFor(int timeout_ms);

  const std::string& url() const { return url_; }
  // What authenticated the messages this process takes, for logs and the
  // archive (BusSecurity::Describe).
  const std::string& security_description() const { return security_description_; }
  // This connection's sender instance (in every message's seal).
  uint64_t instance() const { return sealer_->instance(); }
  uint64_t decode_errors() const { return decode_errors_; }
  // Messages whose CRC did not hold (damaged in flight), dropped.
  uint64_t damaged() const { return damaged_; }
  // Messages refused as forged: no or a wrong MAC, a sender's role that may
  // not publish on the channel, a missing or wrong role signature.
  uint64_t unauthenticated() const { return unauthenticated_; }
  // Messages refused as replayed: seen before, or outside the freshness window.
  uint64_t replayed() const { return replayed_; }
  uint64_t handler_errors() const { return handler_errors_; }
  uint64_t received() const { return received_; }
  uint64_t publish_errors() const { return publish_errors_; }

 private:
  // One subscription: the C callback below hands LCM's buffer to `fn`.
  struct RawSubscription {
    std::function<void(const lcm_recv_buf_t*, const char* channel)> fn;
  };
  // LCM's C callback: user data is the RawSubscription.
  static void DispatchRaw(const lcm_recv_buf_t* rbuf, const char* channel, void* user);
  // Subscribes through LCM's C API (no pointer-to-member dispatch).
  void SubscribeRaw(const std::string& channel_regex, int queue_capacity,
                    std::unique_ptr<RawSubscription> sub);

  LcmBus(std::string url, const BusSecurity& security);
  void NoteDecodeError(const std::string& channel, const std::string& type_name, const char* why);
  // Opens the sealed message `rbuf` holds (once per message, however many
  // subscriptions match it); counts and logs a refusal. Null if refused.
  const BusOpener::Opened* Unseal(const lcm_recv_buf_t* rbuf, const char* channel);
  void NoteHandlerError(const std::string& channel, const std::string& what);
  // Seals `bytes` (an encoding, taken by value: moved from Publish) and sends it.
  Status PublishBytes(const std::string& channel, std::vector<uint8_t> bytes);

  std::string url_;
  std::string security_description_;
  std::unique_ptr<BusSealer> sealer_;
  BusOpener opener_;
  // The message being dispatched (LCM hands one message to every matching
  // subscription in one handle() call): opened once.
  uint64_t dispatch_ = 0;
  uint64_t opened_dispatch_ = ~uint64_t{0};
  BusOpener::Opened opened_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::vector<std::unique_ptr<RawSubscription>> subscriptions_;
  std::atomic<uint64_t> decode_errors_{0};
  std::atomic<uint64_t> damaged_{0};
  std::atomic<uint64_t> unauthenticated_{0};
  std::atomic<uint64_t> replayed_{0};
  std::atomic<uint64_t> handler_errors_{0};
  std::atomic<uint64_t> received_{0};
  std::atomic<uint64_t> publish_errors_{0};
  std::mutex warned_mu_;
  std::set<std::string> warned_channels_;
  std::set<std::string> refused_channels_[3];  // logged once per channel: damaged, forged, replayed
};

// Decodes `size` bytes as T: the fingerprint must match and the message must
// use every byte. Lying length fields fail (never crash). Used by the bus
// and by the fuzzers.
template <typename T>
Status DecodeExactly(const void* data, int size, T* out) {
  try {
    int used = out->decode(data, 0, size);
    if (used < 0) return Status::Corruption("does not decode as " + std::string(T::getTypeName()));
    if (used != size) {
      return Status::Corruption("decodes as " + std::string(T::getTypeName()) + " but leaves " +
                                std::to_string(size - used) + " trailing bytes");
    }
  } catch (const std::exception& e) {
    return Status::Corruption("length fields of " + std::string(T::getTypeName()) + " do not fit (" +
                              e.what() + ")");
  }
  return Status::Ok();
}

template <typename T>
void LcmBus::SubscribeWithOrigin(
    const std::string& channel_regex, int queue_capacity, std::function<bool(const char* channel)> accept,
    std::function<void(const std::string&, T&&, const MessageOrigin&)> handler) {
  auto sub = std::make_unique<RawSubscription>();
  sub->fn = [this, accept = std::move(accept), handler = std::move(handler)](const lcm_recv_buf_t* rbuf,
                                                                             const char* channel) {
    ++received_;
    if (accept && !accept(channel)) return;
    const BusOpener::Opened* opened = Unseal(rbuf, channel);
    if (opened == nullptr) return;
    T msg;
    Status st = DecodeExactly(rbuf->data, static_cast<int>(opened->body_size), &msg);
    if (!st.ok()) {
      NoteDecodeError(channel, std::string(T::getTypeName()), st.message().c_str());
      return;
    }
    try {
      handler(channel, std::move(msg), opened->origin);
    } catch (const std::exception& e) {
      NoteHandlerError(channel, e.what());
    } catch (...) {
      NoteHandlerError(channel, "unknown exception");
    }
  };
  SubscribeRaw(channel_regex, queue_capacity, std::move(sub));
}

// Encodes `msg` into `bytes`; fails on inconsistent length fields.
template <typename T>
Status EncodeMessage(const T& msg, std::vector<uint8_t>* bytes) {
  try {
    int size = msg.getEncodedSize();
    if (size < 0) return Status::InvalidArgument("cannot size " + std::string(T::getTypeName()));
    bytes->reserve(static_cast<size_t>(size) + kMaxUnsignedTrailerBytes);  // room for the seal
    bytes->resize(static_cast<size_t>(size));
    if (msg.encode(bytes->data(), 0, size) != size) {
      return Status::InvalidArgument("cannot encode " + std::string(T::getTypeName()) + " (inconsistent lengths)");
    }
  } catch (const std::exception& e) {
    return Status::InvalidArgument("cannot encode " + std::string(T::getTypeName()) + ": " + e.what());
  }
  return Status::Ok();
}

template <typename T>
Status LcmBus::Publish(const std::string& channel, const T& msg) {
  std::vector<uint8_t> bytes;
  IMUQUAL_RETURN_IF_ERROR(EncodeMessage(msg, &bytes));
  return PublishBytes(channel, std::move(bytes));
}

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_LCM_BUS_H_
