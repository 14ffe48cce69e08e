// The seal of every message on a station bus: who sent it, in what order,
// when, and proof of it. The wire form of a message is its LCM encoding E
// followed by a trailer (multi-byte fields big-endian):
//
//   E | [signature, 64 bytes, if flags & kSigned] | role u8 | 0 u8 |
//     instance u64 | counter u64 | sent_utime i64 | [mac, 16 bytes, if
//     flags & kKeyed] | crc u32 | flags u8 | version u8
//
// - role: the sender's role (BusRole); instance: random per process start;
//   counter: +1 per message the instance sends; sent_utime: the sender's
//   clock (us since the epoch) when it sealed the message.
// - mac, with a station key: the first 16 bytes of keyed BLAKE2b (libsodium
//   crypto_generichash, key = the station key) of the channel name, a zero
//   byte, everything before the mac, then flags and version.
// - crc: CRC-32C of the channel name, a zero byte, everything before the
//   crc (the mac too), then flags and version. A flipped bit anywhere breaks
//   it: damage reads as damage. Without a key it is all there is: damage is
//   caught, nothing is authenticated.
// - signature (flags & kSigned): Ed25519 (the sender role's signing key) of
//   "imuqual-bus-v1", a zero byte, the channel, a zero byte, E, and the
//   header from role to sent_utime, then flags and version.
// - version: kSealVersion.
//
// What a receiver checks, in order, and how it counts a refusal:
// 1. the trailer is well formed and its CRC holds (else: damaged), then its
//    MAC (a MAC that fails, a missing MAC where this process has a key, or a
//    MAC where it has none: unauthenticated);
// 2. the sender's role may publish on the channel (ChannelPolicy), and,
//    where this process holds the roles' public keys, the message is signed
//    by its role's key if the channel requires it: else unauthenticated. A
//    listener that holds the public keys but not the station key (imuqual
//    serve --bus on a host that should not speak) takes signed messages
//    only, by their signatures;
// 3. freshness: sent_utime within max_age_s of the receive time (unless
//    replays were asked for), and the (instance, counter) not seen before
//    (a sliding window per sender): else replayed.
//
// Thread-safety: BusSealer is thread-safe; BusOpener is not (the bus
// thread owns it).
#ifndef IMUQUAL_COMMON_BUS_SEAL_H_
#define IMUQUAL_COMMON_BUS_SEAL_H_

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "common/keys.h"
#include "common/status.h"

namespace imuqual {

enum class BusRole : uint8_t {
  kUnknown = 0,
  kAcquire = 1,
  kAnalyze = 2,
  kStore = 3,
  kStation = 4,  // imuqual run's supervisor (listens only)
  kMonitor = 5,  // imuqual serve --bus (listens only)
  kTool = 6,     // a program of the user's own (tests, scripts)
};
// "acquire", "analyze", ...; "unknown" for anything else.
const char* RoleName(BusRole role);
// The role named `name`; kUnknown if none.
BusRole RoleNamed(std::string_view name);

inline constexpr uint8_t kSealVersion = 1;
inline constexpr uint8_t kSealKeyed = 1;   // flags: the tag is a MAC under the station key
inline constexpr uint8_t kSealSigned = 2;  // flags: a signature precedes the header
inline constexpr size_t kSealHeaderBytes = 26;
inline constexpr size_t kMacBytes = 16;
inline constexpr size_t kSealCrcBytes = 4;
// The largest trailer of an unsigned message (what a batch budget reserves).
inline constexpr size_t kMaxUnsignedTrailerBytes = kSealHeaderBytes + kSealCrcBytes + kMacBytes + 2;

// Who may say what on a station bus: results, curves and decisions come
// only from analyze; run announcements from acquire (and from the store
// re-announcing a run it took over from a silent acquire); raw batches from
// acquire (and from the store resending what it archived); archive
// acknowledgements from the store, flow-control acknowledgements from
// analyze; resend requests from analyze and the store; status from any
// process. Where the roles' public keys are known, every message of those
// roles must carry its role's signature (run announcements with their
// plans, curves, results, decisions, acknowledgements, resend requests,
// status) except raw batches, whose rate makes a signature each too dear:
// they carry the station key's MAC only (README, "Trust": what that leaves
// open). Channels outside the station's contract carry no policy.
struct ChannelPolicy {
  uint32_t allowed = 0;  // bit (1 << role) per role that may publish
  uint32_t signed_ = 0;  // roles whose messages here must be signed
  bool Allows(BusRole r) const { return allowed & (1u << static_cast<int>(r)); }
  bool MustSign(BusRole r) const { return signed_ & (1u << static_cast<int>(r)); }
};
ChannelPolicy PolicyOf(std::string_view channel);

// What a receiver learns of a message's sender from its seal.
struct MessageOrigin {
  BusRole role = BusRole::kUnknown;
  uint64_t instance = 0;
  uint64_t counter = 0;
  int64_t sent_utime = 0;
  int64_t recv_utime = 0;
  bool authenticated = false;   // MAC under the station key held
  bool signed_by_role = false;  // signature of its role's trusted key held
};

// The keys and choices of one process on a bus (common/keys.h).
struct BusSecurity {
  BusRole role = BusRole::kTool;
  // none: CRC only (one host, or --insecure-bus), or, for a listener with
  // `trusted` keys, signed messages only
  std::optional<StationKey> station_key;
  std::optional<SigningKey> signing_key;  // this role's key: signs its verdict-bearing messages
  std::vector<PublicKey> trusted;         // roles' public keys: their messages must be signed
  bool insecure_bus = false;              // a bus beyond this host without a station key, by choice
  bool accept_replay = false;  // take old messages (a recorded log played back), by choice
  double max_age_s = 30;       // freshness window (and the hosts' clock difference allowed)

  // A description for logs and for the archive's runs (bus_auth): what
  // authenticated the messages this process took.
  std::string Describe(bool beyond_host) const;
  // The role's public key, if trusted.
  const PublicKey* TrustedKeyOf(BusRole role) const;
};

// Files and choices as flags give them; Load() reads the keys.
struct BusSecurityFiles {
  std::string key_file;    // station key
  std::string sign_key;    // this role's signing key
  std::string trust_file;  // roles' public keys
  bool insecure_bus = false;
  bool accept_replay = false;
  double max_age_s = 30;
  // Reads the files; the signing key must be of `role`. Errors name the file.
  Result<BusSecurity> Load(BusRole role) const;
};

// Appends the trailer (thread-safe; one per bus connection).
class BusSealer {
 public:
  explicit BusSealer(const BusSecurity& security);
  // Seals the encoding in *bytes (for `channel`) into its wire form; signs
  // it when this process holds a signing key and the channel's policy asks
  // its role to sign.
  void Seal(std::string_view channel, std::vector<uint8_t>* bytes);
  uint64_t instance() const { return instance_; }

 private:
  BusRole role_;
  std::optional<StationKey> key_;
  std::optional<SigningKey> signing_;
  uint64_t instance_;
  std::atomic<uint64_t> counter_{0};
};

// Checks the trailer of received messages and remembers what each sender
// sent (single-threaded: the bus thread).
class BusOpener {
 public:
  enum class Verdict { kOk, kDamaged, kUnauthenticated, kReplayed };
  struct Opened {
    Verdict verdict = Verdict::kDamaged;
    size_t body_size = 0;  // bytes of the LCM encoding
    MessageOrigin origin;
    const char* why = "";  // for a refusal: one phrase, for the log
  };
  explicit BusOpener(BusSecurity security);
  // Opens `size` bytes received on `channel` at `recv_utime` (the host
  // clock, us since the epoch).
  Opened Open(std::string_view channel, const uint8_t* data, size_t size, int64_t recv_utime);
  size_t senders() const { return senders_.size(); }

 private:
  // What a sender has sent: the highest counter and a window of those below.
  // The counters seen of one kind of message of a sender.
  struct Window {
    bool any = false;
    uint64_t highest = 0;
    std::array<uint64_t, 32> bits{};  // bit i: highest - i was seen (2048 counters)
  };
  // A sender is its instance, its role and whether its role's key signed:
  // a message only the station key vouches for (a raw batch) can never move
  // the window of messages a role's key signed, nor of another role.
  struct SenderKey {
    uint64_t instance = 0;
    BusRole role = BusRole::kUnknown;
    bool signed_ = false;
    bool operator==(const SenderKey&) const = default;
  };
  struct SenderKeyHash {
    size_t operator()(const SenderKey& k) const {
      return std::hash<uint64_t>()(k.instance) ^ (static_cast<size_t>(k.role) << 1 | k.signed_);
    }
  };
  struct Sender {
    Window window;
    int64_t last_sent_utime = 0;
  };
  static Verdict Take(Window& w, uint64_t counter, const char** why);
  // kOk, or why (instance, counter) is refused.
  Verdict Remember(const MessageOrigin& o, int64_t now_utime, const char** why);

  BusSecurity security_;
  std::unordered_map<SenderKey, Sender, SenderKeyHash> senders_;
};

// Bounds of the replay memory.
inline constexpr size_t kMaxSenders = 4096;
inline constexpr uint64_t kReplayWindow = 2048;

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_BUS_SEAL_H_
