// The bus seal (common/bus_seal.h) over real UDP multicast (private network
// namespace): a message whose seal does not hold never reaches a handler,
// and is counted as damaged, unauthenticated or replayed. Damaged, forged
// and replayed datagrams are put on the wire by a plain LCM instance beside
// the bus.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <string>
#include <vector>

#include "common/ack.h"
#include "common/channels.h"
#include "common/lcm_bus.h"
#include "imuqual/ack_t.hpp"

namespace imuqual {
namespace {

imuqual::ack_t Ack(int64_t seq) {
  imuqual::ack_t a{};
  a.host_utime = 1;
  a.process = "store";
  a.instance = "host:1";
  a.num_runs = 1;
  a.run_ids = {"RUN-1"};
  a.next_seq = {seq};
  a.run_done = {false};
  return a;
}

std::vector<uint8_t> Sealed(const std::string& channel, const imuqual::ack_t& msg,
                            const BusSecurity& as = BusSecurity{}) {
  std::vector<uint8_t> bytes;
  EXPECT_TRUE(EncodeMessage(msg, &bytes).ok());
  BusSealer(as).Seal(channel, &bytes);
  return bytes;
}

class LcmBusSealTest : public ::testing::Test {
 protected:
  void SetUp() override { Connect(BusSecurity{}); }
  void Connect(const BusSecurity& security) {
    // A port of this process's own (ttl=0: never leaves the host).
    url_ = "udpm://239.255.76.67:" + std::to_string(7300 + getpid() % 500) + "?ttl=0";
    bus_.reset();
    received_.clear();
    auto bus = LcmBus::Open(url_, security);
    ASSERT_TRUE(bus.ok()) << bus.status().ToString();
    bus_ = std::move(*bus);
    raw_ = std::make_unique<lcm::LCM>(url_);
    ASSERT_TRUE(raw_->good());
    bus_->Subscribe<imuqual::ack_t>(
        kChannel, 10000,
        [this](const std::string&, imuqual::ack_t&& a, int64_t) { received_.push_back(a.next_seq[0]); });
  }
  // Dispatches until `n` datagrams were seen by the bus (bounded).
  void PumpUntilSeen(uint64_t n) {
    for (int i = 0; i < 200 && bus_->received() < n; ++i) ASSERT_TRUE(bus_->HandleFor(20).ok());
    ASSERT_TRUE(bus_->HandleFor(20).ok());
  }
  void SendRaw(const std::vector<uint8_t>& bytes) {
    ASSERT_EQ(raw_->publish(kChannel, bytes.data(), static_cast<unsigned>(bytes.size())), 0);
  }

  static constexpr char kChannel[] = "IMUQUAL5_TEST";
  std::string url_;
  std::unique_ptr<LcmBus> bus_;
  std::unique_ptr<lcm::LCM> raw_;
  std::vector<int64_t> received_;
};

TEST_F(LcmBusSealTest, ASealedMessageRoundTripsOnceToEverySubscription) {
  std::vector<MessageOrigin> origins;
  bus_->SubscribeWithOrigin<imuqual::ack_t>(
      kChannel, 100, nullptr,
      [&](const std::string&, imuqual::ack_t&&, const MessageOrigin& o) { origins.push_back(o); });
  ASSERT_TRUE(bus_->Publish(kChannel, Ack(42)).ok());
  SendRaw(Sealed(kChannel, Ack(43)));  // sealed by another sender
  PumpUntilSeen(4);  // two subscriptions see each message
  EXPECT_EQ(received_, (std::vector<int64_t>{42, 43}));
  ASSERT_EQ(origins.size(), 2u);
  EXPECT_EQ(origins[0].instance, bus_->instance());
  EXPECT_EQ(origins[0].role, BusRole::kTool);
  EXPECT_NE(origins[1].instance, bus_->instance());
  EXPECT_EQ(bus_->damaged(), 0u);
  EXPECT_EQ(bus_->replayed(), 0u);  // one message, two subscriptions: opened once
  EXPECT_EQ(bus_->decode_errors(), 0u);
}

TEST_F(LcmBusSealTest, EveryFlippedBitIsDroppedAsDamaged) {
  const std::vector<uint8_t> good = Sealed(kChannel, Ack(7));
  uint64_t sent = 0;
  for (size_t bit = 0; bit < 8 * good.size(); ++bit) {
    std::vector<uint8_t> bad = good;
    bad[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    SendRaw(bad);
    ++sent;
    if (sent % 100 == 0) PumpUntilSeen(sent);  // within the socket's buffer
  }
  PumpUntilSeen(sent);
  ASSERT_EQ(bus_->received(), sent) << "datagrams lost on loopback: the count below would be vacuous";
  EXPECT_TRUE(received_.empty()) << received_.size() << " damaged messages reached the handler";
  EXPECT_EQ(bus_->damaged(), sent);
}

TEST_F(LcmBusSealTest, ADatagramPlayedAgainIsCountedAsReplayed) {
  const std::vector<uint8_t> once = Sealed(kChannel, Ack(5));
  SendRaw(once);
  SendRaw(once);
  SendRaw(once);
  PumpUntilSeen(3);
  EXPECT_EQ(received_, (std::vector<int64_t>{5}));
  EXPECT_EQ(bus_->replayed(), 2u);
}

TEST_F(LcmBusSealTest, WithAStationKeyOnlyItsHoldersAreHeard) {
  BusSecurity keyed;
  keyed.role = BusRole::kTool;
  keyed.station_key = *GenerateStationKey();
  Connect(keyed);
  ASSERT_TRUE(bus_->Publish(kChannel, Ack(1)).ok());      // this station's
  SendRaw(Sealed(kChannel, Ack(2)));                       // no key: refused
  BusSecurity other = keyed;
  other.station_key = *GenerateStationKey();
  SendRaw(Sealed(kChannel, Ack(3), other));                // another station's key: refused
  SendRaw(Sealed(kChannel, Ack(4), keyed));                // another holder of this key
  PumpUntilSeen(4);
  EXPECT_EQ(received_, (std::vector<int64_t>{1, 4}));
  EXPECT_EQ(bus_->unauthenticated(), 2u);
  EXPECT_EQ(bus_->damaged(), 0u);
  EXPECT_NE(bus_->security_description().find("station key " + keyed.station_key->Id()),
            std::string::npos);
}

// Acknowledgements go out together: the runs that progressed within
// kAckFlushPeriodS in as few messages as fit one datagram each, the furthest
// word of each run, an urgent one (a run newly done) at once.
TEST_F(LcmBusSealTest, AcknowledgementsOfManyRunsGoOutTogether) {
  BusSecurity store;  // acknowledgements are the store's (and analyze's) word
  store.role = BusRole::kStore;
  Connect(store);
  std::vector<imuqual::ack_t> got;
  bus_->Subscribe<imuqual::ack_t>(channels::kAck, 1000,
                                  [&](const std::string&, imuqual::ack_t&& a, int64_t) {
                                    got.push_back(std::move(a));
                                  });
  auto runs_heard = [&] {
    size_t n = 0;
    for (const imuqual::ack_t& a : got) n += a.run_ids.size();
    return n;
  };
  AckBatch acks("store", "host:1");
  // 30-byte ids, as `imuqual run` mints them (44 bytes an entry).
  auto id = [](int i) { return "20261128T101500-bench-SIM-" + std::to_string(1000 + i); };
  for (int i = 0; i < 64; ++i) acks.Add(id(i), 10, false);
  acks.Add(id(3), 12, false);  // said again before the flush: the furthest word
  acks.Add(id(3), 11, false);
  ASSERT_TRUE(acks.FlushIfDue(*bus_, 100.0).ok());  // the first: due
  EXPECT_TRUE(acks.empty());
  for (int i = 0; i < 200 && runs_heard() < 64; ++i) ASSERT_TRUE(bus_->HandleFor(20).ok());
  for (const imuqual::ack_t& a : got) {
    size_t entry_bytes = 0;
    for (const std::string& r : a.run_ids) entry_bytes += 4 + r.size() + 1 + 8 + 1;
    EXPECT_LE(entry_bytes, kAckEntryBytes);
    for (int i = 0; i < a.num_runs; ++i) {
      EXPECT_EQ(a.next_seq[i], a.run_ids[i] == id(3) ? 12 : 10) << a.run_ids[i];
    }
  }
  EXPECT_EQ(runs_heard(), 64u);
  EXPECT_LE(got.size(), 4u) << "64 runs of 30-byte ids: 20 per message";
  // Within the period, progress waits for the next flush...
  got.clear();
  acks.Add(id(0), 20, false);
  ASSERT_TRUE(acks.FlushIfDue(*bus_, 100.0 + kAckFlushPeriodS / 2).ok());
  EXPECT_EQ(acks.size(), 1u);
  // ...a repeated "done" too...
  acks.Add(id(2), 40, true);
  ASSERT_TRUE(acks.FlushIfDue(*bus_, 100.0 + kAckFlushPeriodS / 2).ok());
  EXPECT_EQ(acks.size(), 2u);
  // ...and an urgent one goes at once, with what waited.
  acks.Add(id(1), 30, true, /*urgent=*/true);
  ASSERT_TRUE(acks.FlushIfDue(*bus_, 100.0 + kAckFlushPeriodS / 2).ok());
  EXPECT_TRUE(acks.empty());
  for (int i = 0; i < 200 && runs_heard() < 3; ++i) ASSERT_TRUE(bus_->HandleFor(20).ok());
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].run_ids, (std::vector<std::string>{id(0), id(2), id(1)}));
  EXPECT_EQ(got[0].run_done, (std::vector<int8_t>{0, 1, 1}));
}

// The longest acknowledgement (run ids of the longest allowed, 160 bytes; a
// long host:pid instance; a role signature) still goes in one datagram.
TEST(AckBatchTest, TheLongestMessageFitsOneDatagram) {
  BusSecurity store;
  store.role = BusRole::kStore;
  store.station_key = *GenerateStationKey();
  store.signing_key = *GenerateSigningKey("store");
  const std::string instance(64, 'h');
  imuqual::ack_t ack{};
  ack.host_utime = 1;
  ack.process = "store";
  ack.instance = instance;
  for (int i = 0;; ++i) {  // as AckBatch::Flush packs them
    const std::string run(160, static_cast<char>('a' + i));
    size_t bytes = 0;
    for (const std::string& r : ack.run_ids) bytes += 4 + r.size() + 1 + 8 + 1;
    if (!ack.run_ids.empty() && bytes + 4 + run.size() + 1 + 8 + 1 > kAckEntryBytes) break;
    ack.run_ids.push_back(run);
    ack.next_seq.push_back(INT64_MAX);
    ack.run_done.push_back(1);
  }
  ack.num_runs = static_cast<int16_t>(ack.run_ids.size());
  EXPECT_EQ(ack.num_runs, 5);
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(EncodeMessage(ack, &bytes).ok());
  BusSealer(store).Seal(channels::kAck, &bytes);
  // LCM's short-message header: 8 bytes and the channel with its NUL.
  const size_t datagram = 8 + std::string(channels::kAck).size() + 1 + bytes.size();
  EXPECT_LE(datagram, 1400u);
}

TEST(LcmBusOpenTest, ABusBeyondThisHostNeedsAKeyOrAnExplicitChoice) {
  const std::string url = "udpm://239.255.76.67:" + std::to_string(7900 + getpid() % 50) + "?ttl=1";
  auto refused = LcmBus::Open(url, BusSecurity{});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("--insecure-bus"), std::string::npos)
      << refused.status().message();
  BusSecurity insecure;
  insecure.insecure_bus = true;
  auto open = LcmBus::Open(url, insecure);
  ASSERT_TRUE(open.ok()) << open.status().message();
  EXPECT_NE((*open)->security_description().find("--insecure-bus"), std::string::npos);
  BusSecurity keyed;
  keyed.station_key = *GenerateStationKey();
  EXPECT_TRUE(LcmBus::Open(url, keyed).ok());
}

TEST_F(LcmBusSealTest, UnsealedOrForeignChannelMessagesAreRefused) {
  std::vector<uint8_t> unsealed;
  ASSERT_TRUE(EncodeMessage(Ack(1), &unsealed).ok());  // an older station's message
  SendRaw(unsealed);
  SendRaw(Sealed("IMUQUAL5_RESEND", Ack(2)));  // sealed for another channel
  SendRaw({1, 2});                             // shorter than a seal
  PumpUntilSeen(3);
  EXPECT_TRUE(received_.empty());
  EXPECT_EQ(bus_->damaged(), 3u);
}

}  // namespace
}  // namespace imuqual
