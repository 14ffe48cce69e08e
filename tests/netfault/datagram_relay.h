// DatagramRelay: the faults of a network that nftables cannot make by
// itself on this kernel (no NFQUEUE, no netem): datagrams held back so that
// later ones overtake them, and datagrams with one payload bit flipped.
//
// An nftables rule diverts a share of a bus's UDP datagrams to the relay by
// rewriting their destination port (`udp dport set LISTEN_PORT`). The relay
// joins the multicast group on that port, receives each diverted datagram
// with its sender's address, and sends it on to the group on the port it was
// meant for AS IF from that sender: a raw socket with a hand-built IPv4 + UDP
// header carrying the original source address, source port and TTL (LCM
// reassembles a fragmented message per sender address, so the sender must be
// kept). What the relay sends carries a socket mark, so that the diverting
// rule can let it pass (`meta mark != MARK`).
//
// Needs CAP_NET_RAW and CAP_NET_ADMIN (raw socket, SO_MARK): run it in the
// private network namespace of a test, as root there.
#ifndef IMUQUAL_TESTS_NETFAULT_DATAGRAM_RELAY_H_
#define IMUQUAL_TESTS_NETFAULT_DATAGRAM_RELAY_H_

#include <netinet/in.h>

#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "common/status.h"

namespace imuqual::netfault {

struct RelayOptions {
  // Multicast group listened on and sent to.
  std::string group = "239.255.76.67";
  // Port the diverting rule rewrites datagrams to; the relay listens there.
  int listen_port = 0;
  // Port the datagrams were meant for; the relay sends them there.
  int to_port = 0;
  // Each datagram is held for a uniform random time in [0, delay_max_ms] ms
  // before it is sent on; 0 sends each at once, in the order received.
  double delay_max_ms = 0;
  // Probability that one uniformly chosen bit of a datagram's UDP payload is
  // flipped, in [0, 1].
  double flip_probability = 0;
  // SO_MARK of every datagram the relay sends (non-zero).
  uint32_t mark = 0x1e;
  // Seed of the delays, flips and flipped bits.
  uint64_t seed = 1;

  // Ok, or an error that names the first bad field.
  Status Validate() const;
};

// What the relay did; `overtaken`: datagrams sent after one that was
// received after them (reordered among the diverted ones; the undiverted
// ones overtake every held datagram as well).
struct RelayCounts {
  int64_t received = 0;
  int64_t relayed = 0;
  int64_t overtaken = 0;
  int64_t flipped = 0;
  int64_t send_errors = 0;
  int64_t receive_drops = 0;  // dropped by the kernel on the relay's socket
};

// An IPv4 + UDP datagram from `from` to `to` (addresses and ports in network
// byte order, as in a sockaddr_in) with time-to-live `ttl`, the IP header
// checksum set and no UDP checksum (0: allowed for IPv4). The IP id is 0, for
// the kernel to fill in. Precondition: payload.size() <= 65535 - 28.
std::vector<uint8_t> BuildUdpDatagram(const sockaddr_in& from, const sockaddr_in& to, int ttl,
                                      std::span<const uint8_t> payload);

// The channel an LCM datagram names: a whole message or the first fragment
// of one. "(fragment)" for a later fragment, "(not lcm)" for anything else.
std::string LcmChannelOf(std::span<const uint8_t> datagram);

// The kind of a channel: a per-unit channel ("IMUQUAL2_RAW.U01") as its
// prefix and a star ("IMUQUAL2_RAW.*"), any other as is.
std::string ChannelKind(const std::string& channel);

// Flips the bit `bit` (0 = most significant bit of byte 0) of `bytes`.
// Precondition: bit < 8 * bytes.size().
void FlipBit(std::vector<uint8_t>& bytes, size_t bit);

class DatagramRelay {
 public:
  // Opens the listening and the sending socket. Fails with a clear error
  // (bad options, no privilege, no multicast route).
  static Result<std::unique_ptr<DatagramRelay>> Open(const RelayOptions& options);
  ~DatagramRelay();
  DatagramRelay(const DatagramRelay&) = delete;
  DatagramRelay& operator=(const DatagramRelay&) = delete;

  // Relays until ShutdownRequested(), then sends at once what it still holds.
  // Logs every flipped bit (channel, bit, sender). Fails only if receiving
  // fails.
  Status Run();

  const RelayCounts& counts() const { return counts_; }
  // One line of totals ("received=N relayed=N ..."), then one per kind of
  // channel (ChannelKind).
  std::string Report() const;

 private:
  struct Held {
    double due_s;   // monotonic time to send it
    int64_t index;  // order of reception
    std::string channel;
    std::vector<uint8_t> datagram;  // IPv4 + UDP, ready to send
    bool operator>(const Held& o) const {
      return due_s != o.due_s ? due_s > o.due_s : index > o.index;
    }
  };
  struct ChannelCounts {
    int64_t relayed = 0, overtaken = 0, flipped = 0;
  };

  DatagramRelay(const RelayOptions& options, int listen_fd, int send_fd, sockaddr_in to);
  // Receives every datagram waiting on the listening socket.
  Status ReceiveAll(double now_s);
  // Sends the held datagrams due by `now_s` (all of them if `all`).
  void SendDue(double now_s, bool all);

  RelayOptions options_;
  int listen_fd_;
  int send_fd_;
  sockaddr_in to_;
  std::mt19937_64 rng_;
  std::vector<Held> held_;  // a min-heap on (due_s, index)
  int64_t next_index_ = 0;
  int64_t last_sent_index_ = -1;  // highest reception index sent so far
  RelayCounts counts_;
  std::map<std::string, ChannelCounts> by_channel_;  // by ChannelKind
};

}  // namespace imuqual::netfault

#endif  // IMUQUAL_TESTS_NETFAULT_DATAGRAM_RELAY_H_
