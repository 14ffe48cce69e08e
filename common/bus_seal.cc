#include "common/bus_seal.h"

#include <sodium.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/channels.h"
#include "common/clock.h"
#include "common/crc32c.h"

namespace imuqual {
namespace {

constexpr char kSignatureContext[] = "imuqual-bus-v1";

constexpr uint32_t Bit(BusRole r) { return 1u << static_cast<int>(r); }

void PutU64(uint64_t v, uint8_t* out) {
  for (int i = 7; i >= 0; --i) {
    out[i] = static_cast<uint8_t>(v);
    v >>= 8;
  }
}

uint64_t GetU64(const uint8_t* in) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | in[i];
  return v;
}

// CRC-32C of channel, a zero byte, `span` and the last two bytes (flags, version).
uint32_t TrailerCrc(std::string_view channel, const uint8_t* span, size_t span_size,
                    const uint8_t* flags_version) {
  uint32_t crc = Crc32cExtend(0, channel.data(), channel.size());
  const uint8_t zero = 0;
  crc = Crc32cExtend(crc, &zero, 1);
  crc = Crc32cExtend(crc, span, span_size);
  return Crc32cExtend(crc, flags_version, 2);
}

// Keyed BLAKE2b-128 of the same layout.
void TrailerMac(const StationKey& key, std::string_view channel, const uint8_t* span,
                size_t span_size, const uint8_t* flags_version, uint8_t* mac) {
  crypto_generichash_state st;
  crypto_generichash_init(&st, key.bytes.data(), key.bytes.size(), kMacBytes);
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(channel.data()),
                            channel.size());
  const unsigned char zero = 0;
  crypto_generichash_update(&st, &zero, 1);
  crypto_generichash_update(&st, span, span_size);
  crypto_generichash_update(&st, flags_version, 2);
  crypto_generichash_final(&st, mac, kMacBytes);
}

// What a signature covers: context, channel, encoding, header, flags, version.
std::vector<uint8_t> SignedBytes(std::string_view channel, const uint8_t* body, size_t body_size,
                                 const uint8_t* header, const uint8_t* flags_version) {
  std::vector<uint8_t> m;
  m.reserve(sizeof kSignatureContext + channel.size() + 1 + body_size + kSealHeaderBytes + 2);
  m.insert(m.end(), kSignatureContext, kSignatureContext + sizeof kSignatureContext);  // with its 0
  m.insert(m.end(), channel.begin(), channel.end());
  m.push_back(0);
  m.insert(m.end(), body, body + body_size);
  m.insert(m.end(), header, header + kSealHeaderBytes);
  m.insert(m.end(), flags_version, flags_version + 2);
  return m;
}

}  // namespace

const char* RoleName(BusRole role) {
  switch (role) {
    case BusRole::kAcquire:
      return "acquire";
    case BusRole::kAnalyze:
      return "analyze";
    case BusRole::kStore:
      return "store";
    case BusRole::kStation:
      return "station";
    case BusRole::kMonitor:
      return "monitor";
    case BusRole::kTool:
      return "tool";
    case BusRole::kUnknown:
      break;
  }
  return "unknown";
}

BusRole RoleNamed(std::string_view name) {
  for (BusRole r : {BusRole::kAcquire, BusRole::kAnalyze, BusRole::kStore, BusRole::kStation,
                    BusRole::kMonitor, BusRole::kTool}) {
    if (name == RoleName(r)) return r;
  }
  return BusRole::kUnknown;
}

ChannelPolicy PolicyOf(std::string_view channel) {
  const uint32_t acquire = Bit(BusRole::kAcquire), analyze = Bit(BusRole::kAnalyze),
                 store = Bit(BusRole::kStore);
  auto starts = [&](const char* prefix) { return channel.starts_with(prefix); };
  // Who may publish where; with role keys, all of it signed but raw batches.
  if (channel == channels::kRun) return {acquire | store, acquire | store};
  if (starts(channels::kRawPrefix)) return {acquire | store, 0};
  if (starts(channels::kCurvePrefix) || starts(channels::kResultPrefix) ||
      starts(channels::kDecisionPrefix)) {
    return {analyze, analyze};
  }
  if (channel == channels::kAck) return {analyze | store, analyze | store};
  if (channel == channels::kResend) return {analyze | store, analyze | store};
  if (channel == channels::kStatus) return {acquire | analyze | store, acquire | analyze | store};
  return {~0u, 0};  // not a station channel: no policy
}

const PublicKey* BusSecurity::TrustedKeyOf(BusRole role) const {
  for (const PublicKey& k : trusted) {
    if (k.role == RoleName(role)) return &k;
  }
  return nullptr;
}

std::string BusSecurity::Describe(bool beyond_host) const {
  std::string out;
  if (station_key) {
    out = "station key " + station_key->Id();
    if (trusted.empty()) {
      out += "; roles not signed (every process holds the one key)";
    } else {
      out += "; roles signed:";
      for (size_t i = 0; i < trusted.size(); ++i) {
        out += (i ? ", " : " ") + trusted[i].role + " " + trusted[i].Id();
      }
    }
  } else if (beyond_host) {
    out = "no station key: unauthenticated bus beyond this host (--insecure-bus)";
  } else {
    out = "no station key: unauthenticated (ttl=0 keeps what it sends on this host, but any host "
          "that reaches its port can speak on it)";
  }
  if (accept_replay) out += "; replayed messages accepted (--accept-replay)";
  return out;
}

Result<BusSecurity> BusSecurityFiles::Load(BusRole role) const {
  BusSecurity s;
  s.role = role;
  s.insecure_bus = insecure_bus;
  s.accept_replay = accept_replay;
  if (!(max_age_s > 0)) return Status::InvalidArgument("max message age: must be > 0 s");
  s.max_age_s = max_age_s;
  if (!key_file.empty()) {
    auto key = ReadStationKeyFile(key_file);
    if (!key.ok()) return key.status();
    s.station_key = *key;
  }
  if (!sign_key.empty()) {
    auto key = ReadSigningKeyFile(sign_key);
    if (!key.ok()) return key.status();
    if (key->role != RoleName(role)) {
      return Status::InvalidArgument("signing key " + sign_key + " is the " + key->role +
                                     " role's, not " + RoleName(role) + "'s");
    }
    s.signing_key = *key;
  }
  if (!trust_file.empty()) {
    auto keys = ReadPublicKeyFile(trust_file);
    if (!keys.ok()) return keys.status();
    s.trusted = std::move(*keys);
  }
  if (!s.trusted.empty() && !s.station_key && role != BusRole::kMonitor) {
    return Status::InvalidArgument("a trust file (" + trust_file +
                                   ") needs a station key too (--key-file): role signatures "
                                   "ride on an authenticated bus");
  }
  if (!std::isfinite(max_age_s) || max_age_s > 86400) {
    return Status::InvalidArgument("max message age: must be a number of seconds up to a day");
  }
  if (s.signing_key) {
    if (const PublicKey* mine = s.TrustedKeyOf(role);
        mine != nullptr && mine->bytes != s.signing_key->Public().bytes) {
      return Status::InvalidArgument("signing key " + sign_key + " (public key " +
                                     s.signing_key->Public().Id() + ") is not the " +
                                     RoleName(role) + " key the trust file " + trust_file +
                                     " names (" + mine->Id() + ")");
    }
  }
  return s;
}

BusSealer::BusSealer(const BusSecurity& security)
    : role_(security.role), key_(security.station_key), signing_(security.signing_key) {
  (void)InitCrypto();
  randombytes_buf(&instance_, sizeof instance_);
}

void BusSealer::Seal(std::string_view channel, std::vector<uint8_t>* bytes) {
  const bool sign = signing_.has_value() && PolicyOf(channel).MustSign(role_);
  const uint8_t flags_version[2] = {
      static_cast<uint8_t>((key_ ? kSealKeyed : 0) | (sign ? kSealSigned : 0)), kSealVersion};
  uint8_t header[kSealHeaderBytes] = {};
  header[0] = static_cast<uint8_t>(role_);
  PutU64(instance_, header + 2);
  PutU64(counter_.fetch_add(1, std::memory_order_relaxed), header + 10);
  PutU64(static_cast<uint64_t>(NowUtime()), header + 18);
  const size_t body = bytes->size();
  bytes->reserve(body + kSignatureBytes + kSealHeaderBytes + kSealCrcBytes + kMacBytes + 2);
  if (sign) {
    const std::vector<uint8_t> m = SignedBytes(channel, bytes->data(), body, header, flags_version);
    const Signature sig = imuqual::Sign(*signing_, m.data(), m.size());
    bytes->insert(bytes->end(), sig.begin(), sig.end());
  }
  bytes->insert(bytes->end(), header, header + kSealHeaderBytes);
  if (key_) {
    uint8_t mac[kMacBytes];
    TrailerMac(*key_, channel, bytes->data(), bytes->size(), flags_version, mac);
    bytes->insert(bytes->end(), mac, mac + kMacBytes);
  }
  const uint32_t crc = TrailerCrc(channel, bytes->data(), bytes->size(), flags_version);
  for (int shift = 24; shift >= 0; shift -= 8) bytes->push_back(static_cast<uint8_t>(crc >> shift));
  bytes->push_back(flags_version[0]);
  bytes->push_back(flags_version[1]);
}

BusOpener::BusOpener(BusSecurity security) : security_(std::move(security)) { (void)InitCrypto(); }

BusOpener::Opened BusOpener::Open(std::string_view channel, const uint8_t* data, size_t size,
                                  int64_t recv_utime) {
  Opened out;
  out.origin.recv_utime = recv_utime;
  if (size < 2) {
    out.why = "shorter than its seal";
    return out;
  }
  const uint8_t* flags_version = data + size - 2;
  const uint8_t flags = flags_version[0];
  if (flags_version[1] != kSealVersion || (flags & ~(kSealKeyed | kSealSigned)) != 0) {
    out.why = "no seal of this version (damaged, or not a station message)";
    return out;
  }
  const bool keyed = flags & kSealKeyed, is_signed = flags & kSealSigned;
  const size_t mac_size = keyed ? kMacBytes : 0;
  const size_t sig_size = is_signed ? kSignatureBytes : 0;
  const size_t trailer = sig_size + kSealHeaderBytes + kSealCrcBytes + mac_size + 2;
  if (size < trailer) {
    out.why = "shorter than its seal";
    return out;
  }
  const size_t crc_at = size - 2 - kSealCrcBytes;
  const size_t mac_at = crc_at - mac_size;
  uint32_t sent_crc = 0;
  for (size_t i = 0; i < kSealCrcBytes; ++i) sent_crc = (sent_crc << 8) | data[crc_at + i];
  if (sent_crc != TrailerCrc(channel, data, crc_at, flags_version)) {
    out.why = "its CRC-32C does not match (damaged in flight)";
    return out;
  }
  // Intact. Authentic?
  out.verdict = Verdict::kUnauthenticated;
  if (security_.station_key) {
    if (!keyed) {
      out.why = "it carries no MAC (its sender has no station key)";
      return out;
    }
    uint8_t mac[kMacBytes];
    TrailerMac(*security_.station_key, channel, data, mac_at, flags_version, mac);
    if (sodium_memcmp(mac, data + mac_at, kMacBytes) != 0) {
      out.why = "its MAC does not hold (forged or altered, or made with another station's key)";
      return out;
    }
    out.origin.authenticated = true;
  } else if (keyed && security_.trusted.empty()) {
    out.why = "it carries a MAC under a station key this process does not hold (--key-file)";
    return out;
  }
  const size_t body = size - trailer;
  const uint8_t* header = data + body + sig_size;
  out.body_size = body;
  out.origin.role = static_cast<BusRole>(header[0]);
  out.origin.instance = GetU64(header + 2);
  out.origin.counter = GetU64(header + 10);
  out.origin.sent_utime = static_cast<int64_t>(GetU64(header + 18));
  const ChannelPolicy policy = PolicyOf(channel);
  if (!policy.Allows(out.origin.role)) {
    out.why = "its sender's role may not publish on this channel";
    return out;
  }
  // A listener without the station key takes only what a role's key signed.
  const bool must_sign = !security_.trusted.empty() &&
                         (policy.MustSign(out.origin.role) || !security_.station_key);
  if (must_sign) {
    const PublicKey* key = security_.TrustedKeyOf(out.origin.role);
    if (key == nullptr) {
      out.why = "the trust file has no public key for its sender's role";
      return out;
    }
    if (!is_signed) {
      out.why = "it is not signed, and its sender's role must sign on this channel";
      return out;
    }
    Signature sig;
    std::memcpy(sig.data(), data + body, kSignatureBytes);
    const std::vector<uint8_t> m = SignedBytes(channel, data, body, header, flags_version);
    if (!VerifySignature(*key, sig, m.data(), m.size())) {
      out.why = "its signature is not its role's trusted key's";
      return out;
    }
    out.origin.signed_by_role = true;
  }
  // Fresh?
  out.verdict = Remember(out.origin, recv_utime, &out.why);
  return out;
}

BusOpener::Verdict BusOpener::Remember(const MessageOrigin& o, int64_t now_utime,
                                       const char** why) {
  const int64_t max_age_us = static_cast<int64_t>(security_.max_age_s * 1e6);
  if (!security_.accept_replay) {
    // A sent time chosen by a forger cannot overflow the difference: one that
    // does is as far outside the window as a time can be.
    int64_t age = 0;
    const bool overflow = __builtin_sub_overflow(now_utime, o.sent_utime, &age);
    if (overflow ? o.sent_utime < 0 : age > max_age_us) {
      *why = "it is older than the freshness window (a replay, or the hosts' clocks differ)";
      return Verdict::kReplayed;
    }
    if (overflow || age < -max_age_us) {
      *why =
          "it is dated ahead of this host's clock beyond the freshness window (the hosts' clocks "
          "differ?)";
      return Verdict::kReplayed;
    }
  }
  const SenderKey key{o.instance, o.role, o.signed_by_role};
  auto it = senders_.find(key);
  if (it == senders_.end()) {
    if (senders_.size() >= kMaxSenders) {
      // Forget senders silent beyond the window: anything they sent is
      // refused as stale anyway. With replays accepted, the quietest go.
      const int64_t horizon = now_utime - max_age_us;
      std::erase_if(senders_, [&](const auto& kv) { return kv.second.last_sent_utime < horizon; });
      if (senders_.size() >= kMaxSenders && security_.accept_replay) {
        auto oldest =
            std::min_element(senders_.begin(), senders_.end(), [](const auto& a, const auto& b) {
              return a.second.last_sent_utime < b.second.last_sent_utime;
            });
        senders_.erase(oldest);
      }
      if (senders_.size() >= kMaxSenders) {
        *why = "too many senders on the bus at once";
        return Verdict::kUnauthenticated;
      }
    }
    it = senders_.emplace(key, Sender{}).first;
    it->second.last_sent_utime = o.sent_utime;
  }
  Sender& s = it->second;
  const Verdict v = Take(s.window, o.counter, why);
  if (v != Verdict::kOk) return v;
  s.last_sent_utime = std::max(s.last_sent_utime, o.sent_utime);
  return Verdict::kOk;
}

BusOpener::Verdict BusOpener::Take(Window& w, uint64_t counter, const char** why) {
  if (!w.any) {
    w.any = true;
    w.highest = counter;
    w.bits.fill(0);
    w.bits[0] = 1;
    return Verdict::kOk;
  }
  if (counter > w.highest) {
    const uint64_t shift = counter - w.highest;
    if (shift >= kReplayWindow) {
      w.bits.fill(0);
    } else {
      const size_t words = shift / 64, bits = shift % 64;
      for (size_t j = w.bits.size(); j-- > 0;) {
        uint64_t v = j >= words ? w.bits[j - words] << bits : 0;
        if (bits != 0 && j >= words + 1) v |= w.bits[j - words - 1] >> (64 - bits);
        w.bits[j] = v;
      }
    }
    w.bits[0] |= 1;
    w.highest = counter;
    return Verdict::kOk;
  }
  const uint64_t behind = w.highest - counter;
  if (behind >= kReplayWindow) {
    *why = "its counter is far behind what its sender sent since (a replay)";
    return Verdict::kReplayed;
  }
  uint64_t& word = w.bits[behind / 64];
  const uint64_t bit = uint64_t{1} << (behind % 64);
  if (word & bit) {
    *why = "the same message was received before (a replay)";
    return Verdict::kReplayed;
  }
  word |= bit;
  return Verdict::kOk;
}

}  // namespace imuqual
