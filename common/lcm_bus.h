// LcmBus: one LCM instance with typed, checked publish/subscribe (after
// Drake's DrakeLcm). Every message on the wire is sealed: its LCM encoding
// followed by 4 bytes, the CRC-32C (big-endian) of the channel name, a zero
// byte and the encoding. A message is handed to a handler only if its seal
// holds (else it is counted as damaged, e.g. a bit flipped in flight: a lost
// message to the protocol, which repairs it like any other) and it decodes
// completely as the subscribed type: right fingerprint and every byte
// accounted for (else a decode error). Each kind of rejection is logged once
// per channel. No exception escapes an LCM handler: a handler that throws is
// counted as a handler error.
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

class LcmBus {
 public:
  // Connects to `url` (e.g. "udpm://239.255.76.67:7701?ttl=0"); a udpm URL
  // without recv_buf_size gets BusAddress's default. Fails with a clear error
  // if LCM cannot open it.
  static Result<std::unique_ptr<LcmBus>> Open(const std::string& url);
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
                 std::function<void(const std::string&, T&&, int64_t)> handler);

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
  uint64_t decode_errors() const { return decode_errors_; }
  // Messages whose seal did not hold (damaged in flight), dropped.
  uint64_t damaged() const { return damaged_; }
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

  explicit LcmBus(std::string url);
  void NoteDecodeError(const std::string& channel, const std::string& type_name, const char* why);
  // True if the sealed message `rbuf` holds is intact; counts and logs it if not.
  bool Unseal(const lcm_recv_buf_t* rbuf, const char* channel);
  void NoteHandlerError(const std::string& channel, const std::string& what);
  // Seals `bytes` (an encoding, taken by value: moved from Publish) and sends it.
  Status PublishBytes(const std::string& channel, std::vector<uint8_t> bytes);

  std::string url_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::vector<std::unique_ptr<RawSubscription>> subscriptions_;
  std::atomic<uint64_t> decode_errors_{0};
  std::atomic<uint64_t> damaged_{0};
  std::atomic<uint64_t> handler_errors_{0};
  std::atomic<uint64_t> received_{0};
  std::atomic<uint64_t> publish_errors_{0};
  std::mutex warned_mu_;
  std::set<std::string> warned_channels_;
  std::set<std::string> damaged_channels_;
};

// Bytes of the seal that follows every message's encoding on the wire.
inline constexpr uint32_t kSealBytes = 4;

// The seal of a message: CRC-32C of `channel`, a zero byte and the encoding.
uint32_t MessageSeal(const std::string& channel, const void* data, size_t size);

// Appends the seal of the encoding in *bytes (big-endian): the wire form.
void AppendSeal(const std::string& channel, std::vector<uint8_t>* bytes);

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
void LcmBus::Subscribe(const std::string& channel_regex, int queue_capacity,
                       std::function<bool(const char* channel)> accept,
                       std::function<void(const std::string&, T&&, int64_t)> handler) {
  auto sub = std::make_unique<RawSubscription>();
  sub->fn = [this, accept = std::move(accept), handler = std::move(handler)](const lcm_recv_buf_t* rbuf,
                                                                             const char* channel) {
    ++received_;
    if (accept && !accept(channel)) return;
    if (!Unseal(rbuf, channel)) return;
    T msg;
    Status st = DecodeExactly(rbuf->data, static_cast<int>(rbuf->data_size - kSealBytes), &msg);
    if (!st.ok()) {
      NoteDecodeError(channel, std::string(T::getTypeName()), st.message().c_str());
      return;
    }
    try {
      handler(channel, std::move(msg), rbuf->recv_utime);
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
    bytes->reserve(static_cast<size_t>(size) + kSealBytes);  // room for the seal, no realloc
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
