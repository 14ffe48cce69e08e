// The seal of bus messages, without a network: what a receiver takes and
// what it refuses, and why (damaged, unauthenticated, replayed).
#include "common/bus_seal.h"

#include <gtest/gtest.h>
#include <sodium.h>

#include <string>
#include <vector>

#include "common/channels.h"
#include "common/clock.h"
#include "common/crc32c.h"

namespace imuqual {
namespace {

using Verdict = BusOpener::Verdict;

const std::string kResult = channels::Result("SN-1");
const std::string kRaw = channels::Raw("SN-1");

std::vector<uint8_t> Body(const std::string& text) { return {text.begin(), text.end()}; }

std::vector<uint8_t> Sealed(BusSealer& sealer, const std::string& channel,
                            const std::string& text) {
  std::vector<uint8_t> bytes = Body(text);
  sealer.Seal(channel, &bytes);
  return bytes;
}

BusOpener::Opened OpenNow(BusOpener& opener, const std::string& channel,
                          const std::vector<uint8_t>& bytes, int64_t delay_us = 0) {
  return opener.Open(channel, bytes.data(), bytes.size(), NowUtime() + delay_us);
}

struct Station {
  StationKey key = *GenerateStationKey();
  SigningKey acquire = *GenerateSigningKey("acquire");
  SigningKey analyze = *GenerateSigningKey("analyze");
  SigningKey store = *GenerateSigningKey("store");

  BusSecurity As(BusRole role, bool signing = false) const {
    BusSecurity s;
    s.role = role;
    s.station_key = key;
    if (signing) {
      s.trusted = {acquire.Public(), analyze.Public(), store.Public()};
      if (role == BusRole::kAcquire) s.signing_key = acquire;
      if (role == BusRole::kAnalyze) s.signing_key = analyze;
      if (role == BusRole::kStore) s.signing_key = store;
    }
    return s;
  }
};

TEST(BusSealTest, AKeylessSealFollowsTheDocumentedLayout) {
  BusSecurity tool;
  tool.role = BusRole::kTool;
  BusSealer sealer(tool);
  const std::vector<uint8_t> wire = Sealed(sealer, "TEST", "hello");
  // E | role 0 | instance | counter | sent_utime | crc32c | flags version (no mac without a key)
  ASSERT_EQ(wire.size(), 5 + kSealHeaderBytes + kSealCrcBytes + 2);
  EXPECT_EQ(std::string(wire.begin(), wire.begin() + 5), "hello");
  EXPECT_EQ(wire[5], static_cast<uint8_t>(BusRole::kTool));
  EXPECT_EQ(wire[6], 0);
  EXPECT_EQ(wire[wire.size() - 2], 0);  // no key, not signed
  EXPECT_EQ(wire[wire.size() - 1], kSealVersion);
  uint64_t sent = 0;
  for (int i = 0; i < 8; ++i) sent = (sent << 8) | wire[5 + 18 + i];
  EXPECT_NEAR(static_cast<double>(sent), static_cast<double>(NowUtime()), 10e6);
  std::string covered = "TEST";
  covered.push_back('\0');
  covered.append(wire.begin(), wire.begin() + 5 + kSealHeaderBytes);
  covered.append(wire.end() - 2, wire.end());
  const uint32_t crc = Crc32c(covered);
  const size_t at = 5 + kSealHeaderBytes;
  EXPECT_EQ(wire[at], crc >> 24);
  EXPECT_EQ(wire[at + 3], crc & 0xff);

  BusOpener opener(tool);
  const auto opened = OpenNow(opener, "TEST", wire);
  EXPECT_EQ(opened.verdict, Verdict::kOk) << opened.why;
  EXPECT_EQ(opened.body_size, 5u);
  EXPECT_EQ(opened.origin.role, BusRole::kTool);
  EXPECT_EQ(opened.origin.instance, sealer.instance());
  EXPECT_FALSE(opened.origin.authenticated);
}

TEST(BusSealTest, WithAKeyEveryFlippedBitIsCaughtDamageApartFromForgery) {
  Station st;
  BusSealer sealer(st.As(BusRole::kAcquire));
  const std::vector<uint8_t> good = Sealed(sealer, kRaw, "samples of unit SN-1");
  ASSERT_EQ(good.size(), 20 + kMaxUnsignedTrailerBytes);
  int damaged = 0, other = 0;
  for (size_t bit = 0; bit < 8 * good.size(); ++bit) {
    std::vector<uint8_t> bad = good;
    bad[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    BusOpener opener(st.As(BusRole::kStore));  // fresh: no replay memory
    const auto v = OpenNow(opener, kRaw, bad).verdict;
    (v == Verdict::kDamaged ? damaged : other) += 1;
    if (v == Verdict::kOk) ADD_FAILURE() << "bit " << bit << " passed";
  }
  // Every single flipped bit breaks the CRC (it covers the MAC too), so a
  // line with bit errors reads as damage, never as an attack.
  EXPECT_EQ(damaged, static_cast<int>(8 * good.size()));
  EXPECT_EQ(other, 0);
}

TEST(BusSealTest, AForgerWithoutTheKeyIsUnauthenticatedEvenWithAGoodCrc) {
  Station st;
  BusSealer sealer(st.As(BusRole::kAnalyze));
  std::vector<uint8_t> wire = Sealed(sealer, kResult, "verdict FAIL");
  // The forger turns FAIL into PASS and recomputes the CRC as documented;
  // the MAC it cannot recompute.
  wire[8] = 'P', wire[9] = 'A', wire[10] = 'S', wire[11] = 'S';
  const size_t crc_at = wire.size() - 2 - kSealCrcBytes;
  std::string covered = kResult;
  covered.push_back('\0');
  covered.append(wire.begin(), wire.begin() + static_cast<long>(crc_at));
  covered.append(wire.end() - 2, wire.end());
  const uint32_t crc = Crc32c(covered);
  for (int i = 0; i < 4; ++i) wire[crc_at + i] = static_cast<uint8_t>(crc >> (24 - 8 * i));
  BusOpener store(st.As(BusRole::kStore));
  const auto opened = OpenNow(store, kResult, wire);
  EXPECT_EQ(opened.verdict, Verdict::kUnauthenticated);
  EXPECT_NE(std::string(opened.why).find("MAC does not hold"), std::string::npos) << opened.why;

  // Another station's key, no key, and a key where the receiver has none.
  Station other;
  BusSealer foreign(other.As(BusRole::kAnalyze));
  EXPECT_EQ(OpenNow(store, kResult, Sealed(foreign, kResult, "x")).verdict,
            Verdict::kUnauthenticated);
  BusSecurity keyless;
  keyless.role = BusRole::kAnalyze;
  BusSealer open_sealer(keyless);
  EXPECT_EQ(OpenNow(store, kResult, Sealed(open_sealer, kResult, "x")).verdict,
            Verdict::kUnauthenticated);
  BusOpener keyless_store(BusSecurity{});
  EXPECT_EQ(OpenNow(keyless_store, kResult, Sealed(sealer, kResult, "x")).verdict,
            Verdict::kUnauthenticated);
  // The genuine message passes.
  EXPECT_EQ(OpenNow(store, kResult, Sealed(sealer, kResult, "verdict FAIL")).verdict, Verdict::kOk);
}

TEST(BusSealTest, ARoleMaySpeakOnlyWhereThePolicyLetsIt) {
  Station st;
  BusOpener store(st.As(BusRole::kStore));
  BusSealer acquire(st.As(BusRole::kAcquire)), analyze(st.As(BusRole::kAnalyze)),
      tool(st.As(BusRole::kTool));
  EXPECT_EQ(OpenNow(store, kResult, Sealed(acquire, kResult, "r")).verdict,
            Verdict::kUnauthenticated);
  EXPECT_EQ(OpenNow(store, kResult, Sealed(tool, kResult, "r")).verdict, Verdict::kUnauthenticated);
  EXPECT_EQ(OpenNow(store, channels::kRun, Sealed(analyze, channels::kRun, "r")).verdict,
            Verdict::kUnauthenticated);
  EXPECT_EQ(OpenNow(store, channels::kAck, Sealed(acquire, channels::kAck, "a")).verdict,
            Verdict::kUnauthenticated);
  EXPECT_EQ(OpenNow(store, kResult, Sealed(analyze, kResult, "r")).verdict, Verdict::kOk);
  EXPECT_EQ(OpenNow(store, kRaw, Sealed(acquire, kRaw, "b")).verdict, Verdict::kOk);
  EXPECT_EQ(OpenNow(store, "ANY_OTHER", Sealed(tool, "ANY_OTHER", "t")).verdict, Verdict::kOk);
  EXPECT_TRUE(PolicyOf(channels::kRun).Allows(BusRole::kStore));  // re-announcing a taken-over run
  EXPECT_TRUE(PolicyOf(kRaw).Allows(BusRole::kStore));            // resending from the archive
}

TEST(BusSealTest, WithRoleKeysAHostHoldingTheStationKeyCannotSpeakForAnotherRole) {
  Station st;
  BusOpener acquire_side(st.As(BusRole::kAcquire, /*signing=*/true));
  BusSealer analyze(st.As(BusRole::kAnalyze, true));
  const auto good = OpenNow(acquire_side, channels::Decision("SN-1"),
                            Sealed(analyze, channels::Decision("SN-1"), "decided PASS"));
  EXPECT_EQ(good.verdict, Verdict::kOk) << good.why;
  EXPECT_TRUE(good.origin.signed_by_role);

  // A compromised acquire host: it has the station key and its own role key,
  // and claims to be analyze. Signing with its own key, or not at all, fails.
  BusSecurity forger = st.As(BusRole::kAnalyze);
  BusSealer unsigned_forger(forger);
  auto refused = OpenNow(acquire_side, channels::Decision("SN-1"),
                         Sealed(unsigned_forger, channels::Decision("SN-1"), "decided PASS"));
  EXPECT_EQ(refused.verdict, Verdict::kUnauthenticated);
  EXPECT_NE(std::string(refused.why).find("not signed"), std::string::npos) << refused.why;
  SigningKey stolen_role = st.acquire;
  stolen_role.role = "analyze";  // its own secret passed off as analyze's
  forger.signing_key = stolen_role;
  BusSealer wrong_key(forger);
  refused = OpenNow(acquire_side, channels::Decision("SN-1"),
                    Sealed(wrong_key, channels::Decision("SN-1"), "decided PASS"));
  EXPECT_EQ(refused.verdict, Verdict::kUnauthenticated);
  EXPECT_NE(std::string(refused.why).find("signature"), std::string::npos) << refused.why;

  // Raw batches are not signed (the MAC is enough for them) and still pass.
  BusSealer acquire(st.As(BusRole::kAcquire, true));
  BusOpener store(st.As(BusRole::kStore, true));
  const auto batch = OpenNow(store, kRaw, Sealed(acquire, kRaw, "samples"));
  EXPECT_EQ(batch.verdict, Verdict::kOk);
  EXPECT_FALSE(batch.origin.signed_by_role);
  // Everything else of a role with a key must be signed: acknowledgements
  // (the store's and analyze's), status.
  BusSealer store_unsigned(st.As(BusRole::kStore));
  EXPECT_EQ(OpenNow(acquire_side, channels::kAck, Sealed(store_unsigned, channels::kAck, "a")).verdict,
            Verdict::kUnauthenticated);
  BusSealer analyze_unsigned(st.As(BusRole::kAnalyze));
  EXPECT_EQ(OpenNow(acquire_side, channels::kAck, Sealed(analyze_unsigned, channels::kAck, "a")).verdict,
            Verdict::kUnauthenticated);
  EXPECT_EQ(OpenNow(acquire_side, channels::kStatus, Sealed(analyze_unsigned, channels::kStatus, "s")).verdict,
            Verdict::kUnauthenticated);
  EXPECT_EQ(OpenNow(acquire_side, channels::kStatus, Sealed(analyze, channels::kStatus, "s")).verdict,
            Verdict::kOk);
}

TEST(BusSealTest, AListenerWithThePublicKeysAloneTakesWhatTheRolesSigned) {
  Station st;
  BusSecurity listener;
  listener.role = BusRole::kMonitor;
  listener.trusted = {st.acquire.Public(), st.analyze.Public(), st.store.Public()};
  BusOpener monitor(listener);
  BusSealer analyze(st.As(BusRole::kAnalyze, true));
  const auto result = OpenNow(monitor, kResult, Sealed(analyze, kResult, "verdict FAIL"));
  EXPECT_EQ(result.verdict, Verdict::kOk) << result.why;
  EXPECT_TRUE(result.origin.signed_by_role);
  EXPECT_FALSE(result.origin.authenticated);  // no MAC checked: it holds no station key
  // What only the station key vouches for it cannot check, so it refuses it.
  BusSealer acquire(st.As(BusRole::kAcquire, true));
  EXPECT_EQ(OpenNow(monitor, kRaw, Sealed(acquire, kRaw, "samples")).verdict, Verdict::kUnauthenticated);
  BusSealer insider(st.As(BusRole::kAnalyze));  // the station key, no role key
  EXPECT_EQ(OpenNow(monitor, kResult, Sealed(insider, kResult, "verdict PASS")).verdict,
            Verdict::kUnauthenticated);
}

TEST(BusSealTest, AnUnsignedMessageCannotMoveASignedSendersWindow) {
  // An insider with the station key but no role key reads acquire's instance
  // off the wire and sends a raw batch with it and a counter far ahead: the
  // raw window of that instance moves, acquire's signed messages do not.
  Station st;
  BusSealer acquire(st.As(BusRole::kAcquire, true));
  BusOpener store(st.As(BusRole::kStore, true));
  const auto first = Sealed(acquire, channels::kRun, "announce 1");
  const auto second = Sealed(acquire, channels::kRun, "announce 2");
  ASSERT_EQ(OpenNow(store, channels::kRun, first).verdict, Verdict::kOk);
  // The forgery: a raw batch with acquire's instance and a counter of 2^62.
  BusSecurity insider_sec = st.As(BusRole::kAcquire);
  BusSealer insider(insider_sec);
  auto forged = Sealed(insider, kRaw, "b");
  const size_t header = forged.size() - 2 - kSealCrcBytes - kMacBytes - kSealHeaderBytes;
  for (int i = 0; i < 8; ++i) forged[header + 2 + i] = static_cast<uint8_t>(acquire.instance() >> (56 - 8 * i));
  for (int i = 0; i < 8; ++i) forged[header + 10 + i] = static_cast<uint8_t>((uint64_t{1} << 62) >> (56 - 8 * i));
  // ... MAC'd again with the station key it holds (CRC after it).
  {
    std::vector<uint8_t> body(forged.begin(), forged.begin() + static_cast<long>(header + kSealHeaderBytes));
    const uint8_t fv[2] = {forged[forged.size() - 2], forged[forged.size() - 1]};
    uint8_t mac[kMacBytes];
    crypto_generichash_state h;
    crypto_generichash_init(&h, st.key.bytes.data(), st.key.bytes.size(), kMacBytes);
    crypto_generichash_update(&h, reinterpret_cast<const unsigned char*>(kRaw.data()), kRaw.size());
    const unsigned char zero = 0;
    crypto_generichash_update(&h, &zero, 1);
    crypto_generichash_update(&h, body.data(), body.size());
    crypto_generichash_update(&h, fv, 2);
    crypto_generichash_final(&h, mac, kMacBytes);
    std::copy(mac, mac + kMacBytes, forged.begin() + static_cast<long>(header + kSealHeaderBytes));
    std::string covered = kRaw;
    covered.push_back('\0');
    covered.append(forged.begin(), forged.end() - 2 - static_cast<long>(kSealCrcBytes));
    covered.append(forged.end() - 2, forged.end());
    const uint32_t crc = Crc32c(covered);
    const size_t crc_at = forged.size() - 2 - kSealCrcBytes;
    for (int i = 0; i < 4; ++i) forged[crc_at + i] = static_cast<uint8_t>(crc >> (24 - 8 * i));
  }
  const auto poisoned = OpenNow(store, kRaw, forged);
  ASSERT_EQ(poisoned.verdict, Verdict::kOk) << poisoned.why;  // a raw batch the key vouches for
  EXPECT_EQ(poisoned.origin.instance, acquire.instance());
  // acquire's next signed announcement still passes.
  EXPECT_EQ(OpenNow(store, channels::kRun, second).verdict, Verdict::kOk);
}

TEST(BusSealTest, ReplaysAreRefusedAndReorderingIsNot) {
  Station st;
  BusSealer sealer(st.As(BusRole::kAcquire));
  BusOpener opener(st.As(BusRole::kStore));
  std::vector<std::vector<uint8_t>> sent;
  for (int i = 0; i < 3000; ++i) sent.push_back(Sealed(sealer, kRaw, "b" + std::to_string(i)));
  // Out of order within the window: every message taken once.
  for (int i = 100; i < 200; ++i) EXPECT_EQ(OpenNow(opener, kRaw, sent[i]).verdict, Verdict::kOk);
  for (int i = 99; i >= 0; --i)
    EXPECT_EQ(OpenNow(opener, kRaw, sent[i]).verdict, Verdict::kOk) << i;
  // Each again: replayed.
  for (int i = 0; i < 200; ++i)
    EXPECT_EQ(OpenNow(opener, kRaw, sent[i]).verdict, Verdict::kReplayed) << i;
  // A jump ahead by more than the window, then an old one: too far behind.
  EXPECT_EQ(OpenNow(opener, kRaw, sent[2999]).verdict, Verdict::kOk);
  EXPECT_EQ(OpenNow(opener, kRaw, sent[500]).verdict, Verdict::kReplayed);
  EXPECT_EQ(OpenNow(opener, kRaw, sent[2999 - 2047]).verdict, Verdict::kOk);  // the window's edge
  EXPECT_EQ(OpenNow(opener, kRaw, sent[2999 - 2048]).verdict, Verdict::kReplayed);
  // Shifts of every size keep the window's bits where they belong.
  for (int step : {1, 63, 64, 65, 127, 128, 1000}) {
    BusSealer s2(st.As(BusRole::kAcquire));
    BusOpener o2(st.As(BusRole::kStore));
    std::vector<std::vector<uint8_t>> m;
    for (int i = 0; i <= step + 1; ++i) m.push_back(Sealed(s2, kRaw, "x"));
    EXPECT_EQ(OpenNow(o2, kRaw, m[0]).verdict, Verdict::kOk);
    EXPECT_EQ(OpenNow(o2, kRaw, m[step]).verdict, Verdict::kOk);
    EXPECT_EQ(OpenNow(o2, kRaw, m[0]).verdict, Verdict::kReplayed) << step;
    EXPECT_EQ(OpenNow(o2, kRaw, m[1]).verdict, step == 1 ? Verdict::kReplayed : Verdict::kOk)
        << step;
    EXPECT_EQ(OpenNow(o2, kRaw, m[step + 1]).verdict, Verdict::kOk) << step;
    EXPECT_EQ(OpenNow(o2, kRaw, m[step]).verdict, Verdict::kReplayed) << step;
  }
}

TEST(BusSealTest, OldMessagesAreRefusedUnlessReplaysWereAskedFor) {
  Station st;
  BusSealer sealer(st.As(BusRole::kAcquire));
  const auto msg = Sealed(sealer, kRaw, "captured an hour ago");
  BusOpener fresh_store(st.As(BusRole::kStore));
  const auto later = OpenNow(fresh_store, kRaw, msg, /*delay_us=*/90'000'000);
  EXPECT_EQ(later.verdict, Verdict::kReplayed);
  EXPECT_NE(std::string(later.why).find("older than the freshness window"), std::string::npos);
  EXPECT_EQ(OpenNow(fresh_store, kRaw, msg, -90'000'000).verdict,
            Verdict::kReplayed);                                                 // clocks apart
  EXPECT_EQ(OpenNow(fresh_store, kRaw, msg, 29'000'000).verdict, Verdict::kOk);  // within 30 s

  BusSecurity replaying = st.As(BusRole::kStore);
  replaying.accept_replay = true;
  BusOpener replay_store(replaying);
  EXPECT_EQ(OpenNow(replay_store, kRaw, msg, 3600'000'000LL).verdict, Verdict::kOk);
  // Even then, a message is taken once.
  EXPECT_EQ(OpenNow(replay_store, kRaw, msg, 3600'000'000LL).verdict, Verdict::kReplayed);
}

// A keyless seal changed by hand, its CRC made good again (a keyless bus
// authenticates nothing: anyone can do this there).
void Reseal(const std::string& channel, std::vector<uint8_t>* wire) {
  const size_t crc_at = wire->size() - 2 - kSealCrcBytes;
  std::string covered = channel;
  covered.push_back('\0');
  covered.append(wire->begin(), wire->begin() + static_cast<long>(crc_at));
  covered.append(wire->end() - 2, wire->end());
  const uint32_t crc = Crc32c(covered);
  for (int i = 0; i < 4; ++i) (*wire)[crc_at + i] = static_cast<uint8_t>(crc >> (24 - 8 * i));
}

void SetSentUtime(int64_t utime, size_t body_size, std::vector<uint8_t>* wire) {
  for (int i = 0; i < 8; ++i)
    (*wire)[body_size + 18 + i] = static_cast<uint8_t>(utime >> (56 - 8 * i));
}

TEST(BusSealTest, SendersAreBounded) {
  BusSecurity as_acquire;
  as_acquire.role = BusRole::kAcquire;
  // At most kMaxSenders remembered; those silent beyond the window are
  // forgotten to make room (anything they sent is stale by then).
  const int64_t now = NowUtime();
  BusOpener bounded(BusSecurity{});
  for (size_t i = 0; i < kMaxSenders; ++i) {
    BusSealer s(as_acquire);
    auto m = Sealed(s, kRaw, "b");
    SetSentUtime(now - 25'000'000, 1, &m);
    Reseal(kRaw, &m);
    ASSERT_EQ(bounded.Open(kRaw, m.data(), m.size(), now).verdict, Verdict::kOk);
  }
  BusSealer one_more(as_acquire);
  auto m = Sealed(one_more, kRaw, "b");
  SetSentUtime(now, 1, &m);
  Reseal(kRaw, &m);
  EXPECT_EQ(bounded.Open(kRaw, m.data(), m.size(), now).verdict, Verdict::kUnauthenticated);
  EXPECT_EQ(bounded.senders(), kMaxSenders);
  EXPECT_EQ(bounded.Open(kRaw, m.data(), m.size(), now + 10'000'000).verdict, Verdict::kOk);
  EXPECT_EQ(bounded.senders(), 1u);
}

TEST(BusSealTest, KeysLoadFromFilesAndMustMatchTheirRole) {
  char tmpl[] = "/tmp/imuqual-busseal-XXXXXX";
  ASSERT_NE(mkdtemp(tmpl), nullptr);
  const std::string dir = tmpl;
  Station st;
  ASSERT_TRUE(WriteStationKeyFile(dir + "/station.key", st.key).ok());
  ASSERT_TRUE(WriteSigningKeyFiles(dir + "/analyze.key", st.analyze).ok());
  BusSecurityFiles files;
  files.key_file = dir + "/station.key";
  files.sign_key = dir + "/analyze.key";
  files.trust_file = dir + "/analyze.key.pub";
  auto loaded = files.Load(BusRole::kAnalyze);
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  EXPECT_EQ(loaded->station_key->bytes, st.key.bytes);
  EXPECT_NE(loaded->Describe(false).find("station key " + st.key.Id()), std::string::npos);
  auto wrong_role = files.Load(BusRole::kStore);
  ASSERT_FALSE(wrong_role.ok());
  EXPECT_NE(wrong_role.status().message().find("analyze role's, not store's"), std::string::npos);
  files.key_file.clear();
  files.sign_key.clear();
  auto trust_without_key = files.Load(BusRole::kStore);
  ASSERT_FALSE(trust_without_key.ok());
  EXPECT_NE(trust_without_key.status().message().find("needs a station key"), std::string::npos);
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace
}  // namespace imuqual
