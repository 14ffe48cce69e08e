#include "tests/netfault/datagram_relay.h"

#include <arpa/inet.h>
#include <netinet/ip.h>
#include <netinet/udp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <functional>
#include <sstream>

#include "common/clock.h"
#include "common/log.h"
#include "common/shutdown.h"

namespace imuqual::netfault {
namespace {

constexpr size_t kIpHeaderBytes = 20;
constexpr size_t kUdpHeaderBytes = 8;
constexpr size_t kMaxPayloadBytes = 65535 - kIpHeaderBytes - kUdpHeaderBytes;
// Beyond this many held datagrams a new one is sent at once: memory stays
// bounded (8192 x 64 KB at most) whatever the rate.
constexpr size_t kMaxHeld = 8192;
// Longest wait in poll(), so that a shutdown request is seen promptly.
constexpr int kMaxPollMs = 100;
// Requested kernel receive buffer of the listening socket.
constexpr int kReceiveBufferBytes = 8 * 1024 * 1024;

// LCM's datagram headers (lcm_udpm): a whole message is "LC02", seqno,
// channel\0, data; a fragment is "LC03", seqno, message size, fragment
// offset, fragment number (16 bits), fragment count (16 bits), then, in
// fragment 0 only, channel\0.
constexpr uint32_t kLcmShortMagic = 0x4c433032;
constexpr uint32_t kLcmFragmentMagic = 0x4c433033;
constexpr size_t kLcmShortHeaderBytes = 8;
constexpr size_t kLcmFragmentHeaderBytes = 20;

uint32_t ReadBigEndian32(std::span<const uint8_t> b, size_t at) {
  return (uint32_t{b[at]} << 24) | (uint32_t{b[at + 1]} << 16) | (uint32_t{b[at + 2]} << 8) |
         uint32_t{b[at + 3]};
}

std::string CString(std::span<const uint8_t> b, size_t at) {
  const auto begin = b.begin() + static_cast<std::ptrdiff_t>(std::min(at, b.size()));
  const auto end = std::find(begin, b.end(), uint8_t{0});
  if (end == b.end()) return "(not lcm)";
  return std::string(begin, end);
}

// RFC 791 header checksum: the one's complement of the one's complement sum
// of the header's 16-bit words (with the checksum field 0).
uint16_t Ipv4HeaderChecksum(const uint8_t* header, size_t bytes) {
  uint32_t sum = 0;
  for (size_t i = 0; i + 1 < bytes; i += 2) sum += (uint32_t{header[i]} << 8) | header[i + 1];
  while (sum >> 16) sum = (sum & 0xffff) + (sum >> 16);
  return static_cast<uint16_t>(~sum);
}

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

Status RelayOptions::Validate() const {
  in_addr addr{};
  if (::inet_pton(AF_INET, group.c_str(), &addr) != 1 || !IN_MULTICAST(ntohl(addr.s_addr))) {
    return Status::InvalidArgument("group: '" + group + "' is not an IPv4 multicast address");
  }
  if (listen_port <= 0 || listen_port > 65535) {
    return Status::InvalidArgument("listen_port: must be in 1..65535");
  }
  if (to_port <= 0 || to_port > 65535)
    return Status::InvalidArgument("to_port: must be in 1..65535");
  if (to_port == listen_port)
    return Status::InvalidArgument("to_port: must differ from listen_port");
  if (!(delay_max_ms >= 0 && std::isfinite(delay_max_ms))) {
    return Status::InvalidArgument("delay_max_ms: must be finite and >= 0");
  }
  if (!(flip_probability >= 0 && flip_probability <= 1)) {
    return Status::InvalidArgument("flip_probability: must be in [0, 1]");
  }
  if (mark == 0) return Status::InvalidArgument("mark: must be non-zero");
  return Status::Ok();
}

std::vector<uint8_t> BuildUdpDatagram(const sockaddr_in& from, const sockaddr_in& to, int ttl,
                                      std::span<const uint8_t> payload) {
  const size_t total = kIpHeaderBytes + kUdpHeaderBytes + payload.size();
  std::vector<uint8_t> d(total, 0);
  iphdr ip{};
  ip.version = 4;
  ip.ihl = kIpHeaderBytes / 4;
  ip.tot_len = htons(static_cast<uint16_t>(total));
  ip.ttl = static_cast<uint8_t>(ttl);
  ip.protocol = IPPROTO_UDP;
  ip.saddr = from.sin_addr.s_addr;
  ip.daddr = to.sin_addr.s_addr;
  std::memcpy(d.data(), &ip, kIpHeaderBytes);
  const uint16_t check = Ipv4HeaderChecksum(d.data(), kIpHeaderBytes);
  d[10] = static_cast<uint8_t>(check >> 8);
  d[11] = static_cast<uint8_t>(check & 0xff);
  udphdr udp{};
  udp.source = from.sin_port;
  udp.dest = to.sin_port;
  udp.len = htons(static_cast<uint16_t>(kUdpHeaderBytes + payload.size()));
  udp.check = 0;
  std::memcpy(d.data() + kIpHeaderBytes, &udp, kUdpHeaderBytes);
  if (!payload.empty()) {
    std::memcpy(d.data() + kIpHeaderBytes + kUdpHeaderBytes, payload.data(), payload.size());
  }
  return d;
}

std::string ChannelKind(const std::string& channel) {
  const size_t dot = channel.find('.');
  return dot == std::string::npos ? channel : channel.substr(0, dot + 1) + "*";
}

std::string LcmChannelOf(std::span<const uint8_t> d) {
  if (d.size() < kLcmShortHeaderBytes) return "(not lcm)";
  const uint32_t magic = ReadBigEndian32(d, 0);
  if (magic == kLcmShortMagic) return CString(d, kLcmShortHeaderBytes);
  if (magic != kLcmFragmentMagic || d.size() < kLcmFragmentHeaderBytes) return "(not lcm)";
  const uint16_t fragment_no = static_cast<uint16_t>((d[16] << 8) | d[17]);
  return fragment_no == 0 ? CString(d, kLcmFragmentHeaderBytes) : "(fragment)";
}

void FlipBit(std::vector<uint8_t>& bytes, size_t bit) {
  bytes[bit / 8] ^= static_cast<uint8_t>(0x80u >> (bit % 8));
}

Result<std::unique_ptr<DatagramRelay>> DatagramRelay::Open(const RelayOptions& options) {
  IMUQUAL_RETURN_IF_ERROR(options.Validate());
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(options.to_port));
  ::inet_pton(AF_INET, options.group.c_str(), &to.sin_addr);

  const int listen_fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (listen_fd < 0) return Status::Unavailable(Errno("socket"));
  // Owned from here on, closed on every failure below.
  auto fail = [&](const std::string& what, int send_fd = -1) {
    Status s = Status::Unavailable(Errno(what));
    ::close(listen_fd);
    if (send_fd >= 0) ::close(send_fd);
    return s;
  };
  const int one = 1;
  if (::setsockopt(listen_fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) {
    return fail("SO_REUSEADDR");
  }
  // Past net.core.rmem_max when privileged; else what the kernel allows.
  if (::setsockopt(listen_fd, SOL_SOCKET, SO_RCVBUFFORCE, &kReceiveBufferBytes,
                   sizeof kReceiveBufferBytes) != 0) {
    (void)::setsockopt(listen_fd, SOL_SOCKET, SO_RCVBUF, &kReceiveBufferBytes,
                       sizeof kReceiveBufferBytes);
  }
  // The sender's TTL with every datagram, and the kernel's drop count.
  if (::setsockopt(listen_fd, IPPROTO_IP, IP_RECVTTL, &one, sizeof one) != 0) {
    return fail("IP_RECVTTL");
  }
  if (::setsockopt(listen_fd, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one) != 0) {
    return fail("SO_RXQ_OVFL");
  }
  sockaddr_in bind_addr{};
  bind_addr.sin_family = AF_INET;
  bind_addr.sin_port = htons(static_cast<uint16_t>(options.listen_port));
  bind_addr.sin_addr.s_addr = htonl(INADDR_ANY);
  if (::bind(listen_fd, reinterpret_cast<const sockaddr*>(&bind_addr), sizeof bind_addr) != 0) {
    return fail("bind to port " + std::to_string(options.listen_port));
  }
  ip_mreq join{};
  join.imr_multiaddr = to.sin_addr;
  join.imr_interface.s_addr = htonl(INADDR_ANY);
  if (::setsockopt(listen_fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &join, sizeof join) != 0) {
    return fail("joining " + options.group + " (is there a multicast route?)");
  }

  // IPPROTO_RAW: the relay writes the whole IP header (IP_HDRINCL).
  const int send_fd = ::socket(AF_INET, SOCK_RAW | SOCK_CLOEXEC, IPPROTO_RAW);
  if (send_fd < 0) return fail("raw socket (needs CAP_NET_RAW)");
  const unsigned mark = options.mark;
  if (::setsockopt(send_fd, SOL_SOCKET, SO_MARK, &mark, sizeof mark) != 0) {
    return fail("SO_MARK (needs CAP_NET_ADMIN)", send_fd);
  }
  // Delivered to the listeners on this host: the receivers are local.
  const unsigned char loop = 1;
  if (::setsockopt(send_fd, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop) != 0) {
    return fail("IP_MULTICAST_LOOP", send_fd);
  }
  return std::unique_ptr<DatagramRelay>(new DatagramRelay(options, listen_fd, send_fd, to));
}

DatagramRelay::DatagramRelay(const RelayOptions& options, int listen_fd, int send_fd,
                             sockaddr_in to)
    : options_(options), listen_fd_(listen_fd), send_fd_(send_fd), to_(to), rng_(options.seed) {}

DatagramRelay::~DatagramRelay() {
  ::close(listen_fd_);
  ::close(send_fd_);
}

Status DatagramRelay::Run() {
  while (!ShutdownRequested()) {
    double now = MonotonicSeconds();
    SendDue(now, false);
    int timeout_ms = kMaxPollMs;
    if (!held_.empty()) {
      const double wait_ms = std::ceil((held_.front().due_s - now) * 1000);
      timeout_ms = static_cast<int>(std::clamp(wait_ms, 0.0, double{kMaxPollMs}));
    }
    pollfd p{listen_fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, timeout_ms);
    if (ready < 0 && errno != EINTR) return Status::IoError(Errno("poll"));
    if (ready > 0) IMUQUAL_RETURN_IF_ERROR(ReceiveAll(MonotonicSeconds()));
  }
  // Nothing the relay took is lost by stopping it.
  IMUQUAL_RETURN_IF_ERROR(ReceiveAll(MonotonicSeconds()));
  SendDue(MonotonicSeconds(), true);
  return Status::Ok();
}

Status DatagramRelay::ReceiveAll(double now_s) {
  std::vector<uint8_t> payload(kMaxPayloadBytes);
  alignas(cmsghdr) char control[256];
  std::uniform_real_distribution<double> delay_ms(0, options_.delay_max_ms);
  std::bernoulli_distribution flip(options_.flip_probability);
  for (;;) {
    sockaddr_in from{};
    iovec iov{payload.data(), payload.size()};
    msghdr m{};
    m.msg_name = &from;
    m.msg_namelen = sizeof from;
    m.msg_iov = &iov;
    m.msg_iovlen = 1;
    m.msg_control = control;
    m.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(listen_fd_, &m, MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) return Status::Ok();
      if (errno == EINTR) continue;
      return Status::IoError(Errno("recvmsg"));
    }
    int ttl = 0;
    for (cmsghdr* c = CMSG_FIRSTHDR(&m); c != nullptr; c = CMSG_NXTHDR(&m, c)) {
      if (c->cmsg_level == IPPROTO_IP && c->cmsg_type == IP_TTL) {
        std::memcpy(&ttl, CMSG_DATA(c), sizeof ttl);
      } else if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
        uint32_t drops = 0;
        std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
        counts_.receive_drops = drops;  // cumulative since the socket opened
      }
    }
    ++counts_.received;
    std::vector<uint8_t> bytes(payload.begin(), payload.begin() + n);
    const std::string channel = LcmChannelOf(bytes);
    if (n > 0 && flip(rng_)) {
      const size_t bit = std::uniform_int_distribution<size_t>(0, 8 * bytes.size() - 1)(rng_);
      FlipBit(bytes, bit);
      ++counts_.flipped;
      ++by_channel_[ChannelKind(channel)].flipped;
      char sender[INET_ADDRSTRLEN] = "";
      ::inet_ntop(AF_INET, &from.sin_addr, sender, sizeof sender);
      LogInfo("flipped bit " + std::to_string(bit) + " (byte " + std::to_string(bit / 8) +
              ") of a " + std::to_string(n) + "-byte datagram on " + channel + " from " + sender +
              ":" + std::to_string(ntohs(from.sin_port)));
    }
    Held h;
    h.due_s = held_.size() < kMaxHeld && options_.delay_max_ms > 0 ? now_s + delay_ms(rng_) / 1000
                                                                   : now_s;
    h.index = next_index_++;
    h.channel = channel;
    h.datagram = BuildUdpDatagram(from, to_, ttl, bytes);
    held_.push_back(std::move(h));
    std::push_heap(held_.begin(), held_.end(), std::greater<>());
  }
}

void DatagramRelay::SendDue(double now_s, bool all) {
  while (!held_.empty() && (all || held_.front().due_s <= now_s)) {
    std::pop_heap(held_.begin(), held_.end(), std::greater<>());
    Held h = std::move(held_.back());
    held_.pop_back();
    const ssize_t sent = ::sendto(send_fd_, h.datagram.data(), h.datagram.size(), 0,
                                  reinterpret_cast<const sockaddr*>(&to_), sizeof to_);
    if (sent != static_cast<ssize_t>(h.datagram.size())) {
      ++counts_.send_errors;
      LogWarning(Errno("sending a " + std::to_string(h.datagram.size()) + "-byte datagram on " +
                       h.channel));
      continue;
    }
    ChannelCounts& c = by_channel_[ChannelKind(h.channel)];
    ++counts_.relayed;
    ++c.relayed;
    if (h.index < last_sent_index_) {
      ++counts_.overtaken;
      ++c.overtaken;
    }
    last_sent_index_ = std::max(last_sent_index_, h.index);
  }
}

std::string DatagramRelay::Report() const {
  std::ostringstream out;
  out << "received=" << counts_.received << " relayed=" << counts_.relayed
      << " overtaken=" << counts_.overtaken << " flipped=" << counts_.flipped
      << " send_errors=" << counts_.send_errors << " receive_drops=" << counts_.receive_drops;
  for (const auto& [channel, c] : by_channel_) {
    out << "\n  " << channel << ": relayed=" << c.relayed << " overtaken=" << c.overtaken
        << " flipped=" << c.flipped;
  }
  return out.str();
}

}  // namespace imuqual::netfault
