// The relay's pure parts: the datagram it builds, the channel it names, the
// bit it flips, the options it refuses. (Its sockets: kernel_fault_test.)
#include "tests/netfault/datagram_relay.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace imuqual::netfault {
namespace {

sockaddr_in Address(const char* ip, int port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  ::inet_pton(AF_INET, ip, &a.sin_addr);
  return a;
}

uint16_t Be16(const std::vector<uint8_t>& d, size_t at) {
  return static_cast<uint16_t>((d[at] << 8) | d[at + 1]);
}

TEST(DatagramRelayTest, BuildsTheIpv4AndUdpHeaderOfTheOriginalSender) {
  // GIVEN a payload from 10.1.2.3:40000 to a group's port 7701, ttl 0
  const std::vector<uint8_t> payload = {'L', 'C', '0', '2', 1, 2, 3};
  const auto d =
      BuildUdpDatagram(Address("10.1.2.3", 40000), Address("239.255.76.67", 7701), 0, payload);
  // THEN the header says so, byte for byte (RFC 791, RFC 768)
  ASSERT_EQ(d.size(), 20u + 8u + payload.size());
  EXPECT_EQ(d[0], 0x45);            // version 4, 5 words
  EXPECT_EQ(Be16(d, 2), d.size());  // total length
  EXPECT_EQ(d[8], 0);               // ttl
  EXPECT_EQ(d[9], 17);              // UDP
  EXPECT_EQ(std::vector<uint8_t>(d.begin() + 12, d.begin() + 16),
            (std::vector<uint8_t>{10, 1, 2, 3}));
  EXPECT_EQ(std::vector<uint8_t>(d.begin() + 16, d.begin() + 20),
            (std::vector<uint8_t>{239, 255, 76, 67}));
  EXPECT_EQ(Be16(d, 20), 40000);  // source port
  EXPECT_EQ(Be16(d, 22), 7701);   // destination port
  EXPECT_EQ(Be16(d, 24), 8 + payload.size());
  EXPECT_EQ(Be16(d, 26), 0);  // no UDP checksum
  EXPECT_EQ(std::vector<uint8_t>(d.begin() + 28, d.end()), payload);
  // AND the header's one's complement sum, checksum included, is all ones.
  uint32_t sum = 0;
  for (size_t i = 0; i < 20; i += 2) sum += Be16(d, i);
  while (sum >> 16) sum = (sum & 0xffff) + (sum >> 16);
  EXPECT_EQ(sum, 0xffffu);
}

std::vector<uint8_t> Bytes(const std::string& s) { return {s.begin(), s.end()}; }

TEST(DatagramRelayTest, NamesTheChannelOfAnLcmDatagram) {
  using namespace std::string_literals;
  // A whole message: magic, seqno, channel\0, data.
  EXPECT_EQ(LcmChannelOf(Bytes("LC02\0\0\0\7IMUQUAL2_ACK\0data"s)), "IMUQUAL2_ACK");
  // Fragment 0 names it after the 20-byte fragment header; later ones do not.
  const std::string header = "LC03\0\0\0\7\0\0\1\0\0\0\0\0"s;
  EXPECT_EQ(LcmChannelOf(Bytes(header + "\0\0\0\2IMUQUAL2_RUN\0data"s)), "IMUQUAL2_RUN");
  EXPECT_EQ(LcmChannelOf(Bytes(header + "\0\1\0\2data"s)), "(fragment)");
  EXPECT_EQ(LcmChannelOf(Bytes("LC02\0\0\0\7no terminator"s)), "(not lcm)");
  EXPECT_EQ(LcmChannelOf(Bytes("hello, world")), "(not lcm)");
  EXPECT_EQ(LcmChannelOf({}), "(not lcm)");
}

TEST(DatagramRelayTest, CountsPerUnitChannelsAsOneKind) {
  EXPECT_EQ(ChannelKind("IMUQUAL2_RAW.LOT-U01"), "IMUQUAL2_RAW.*");
  EXPECT_EQ(ChannelKind("IMUQUAL2_ACK"), "IMUQUAL2_ACK");
}

TEST(DatagramRelayTest, FlipsExactlyTheBitItIsGiven) {
  std::vector<uint8_t> b = {0x00, 0xff};
  FlipBit(b, 0);
  EXPECT_EQ(b, (std::vector<uint8_t>{0x80, 0xff}));
  FlipBit(b, 15);
  EXPECT_EQ(b, (std::vector<uint8_t>{0x80, 0xfe}));
  FlipBit(b, 0);
  FlipBit(b, 15);
  EXPECT_EQ(b, (std::vector<uint8_t>{0x00, 0xff}));
}

TEST(DatagramRelayTest, RefusedOptionsNameTheField) {
  RelayOptions ok;
  ok.listen_port = 7702;
  ok.to_port = 7701;
  EXPECT_TRUE(ok.Validate().ok());
  auto with = [&](auto change) {
    RelayOptions o = ok;
    change(o);
    return o.Validate().message();
  };
  EXPECT_NE(with([](RelayOptions& o) { o.group = "10.0.0.1"; }).find("group"), std::string::npos);
  EXPECT_NE(with([](RelayOptions& o) { o.listen_port = 0; }).find("listen_port"),
            std::string::npos);
  EXPECT_NE(with([](RelayOptions& o) { o.to_port = 7702; }).find("to_port"), std::string::npos);
  EXPECT_NE(with([](RelayOptions& o) { o.delay_max_ms = -1; }).find("delay_max_ms"),
            std::string::npos);
  EXPECT_NE(with([](RelayOptions& o) { o.flip_probability = 1.5; }).find("flip_probability"),
            std::string::npos);
  EXPECT_NE(with([](RelayOptions& o) { o.mark = 0; }).find("mark"), std::string::npos);
}

}  // namespace
}  // namespace imuqual::netfault
