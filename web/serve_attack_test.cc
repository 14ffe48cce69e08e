// Attacks on `imuqual serve` (the binary), each in a private network
// namespace (tests/netns_run): every address used is a loopback address of
// that namespace, 127.0.0.0/8, which lets one test speak from many
// addresses.
//
//   - Slow connections: 200 connections that trickle header lines (from one
//     address, from 200 addresses; over TLS, a handshake record that never
//     ends) do not keep a legitimate request from being answered, and the
//     server closes every one of them although each keeps sending.
//   - Token guessing: the guesses the server answers collapse to a handful
//     (the rest get 429 without their token looked at), another address
//     with the right token is served meanwhile, and the log names the
//     address and the counts, never a token.
//   - A second server on a port in use exits with one line and an error,
//     and the first one goes on serving alone.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/subprocess.h"
#include "store/archive.h"
#include "tests/test_util.h"

namespace imuqual::web {
namespace {

using Clock = std::chrono::steady_clock;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// An archive with one finished run in lot `lot` (enough for every page).
std::string MakeArchive(const testing::TempDir& dir, const std::string& name,
                        const std::string& lot) {
  const std::string db = dir.path(name);
  auto a = store::Archive::Open(db, store::Archive::Mode::kWrite);
  EXPECT_TRUE(a.ok()) << a.status().ToString();
  store::RunInfo r;
  r.run_id = "R-" + lot;
  r.serial = "SN-1";
  r.lot = lot;
  r.station = "attack";
  r.start_utime = 1'800'000'000'000'000;
  r.nominal_rate_hz = 100;
  r.axes = {{"gx", pb::GYRO}};
  r.state = "complete";
  r.end_utime = r.start_utime + 1'000'000;
  auto key = (*a)->UpsertRun(r);
  EXPECT_TRUE(key.ok());
  return db;
}

// `imuqual serve ARGS` with its output in `log`; Started() waits for its URL.
class Serve {
 public:
  Serve(std::vector<std::string> args, std::string log) : log_(std::move(log)) {
    args.insert(args.begin(), {testing::Bin("imuqual"), "serve"});
    auto p = Subprocess::Start(args, log_);
    EXPECT_TRUE(p.ok()) << p.status().ToString();
    if (p.ok()) process_.emplace(std::move(*p));
  }
  // The port once the server prints its URL (bounded wait), or -1.
  int Started() {
    const std::regex url("serving .* at https?://127\\.0\\.0\\.1:(\\d+)/");
    for (int i = 0; i < 200 && process_ && !process_->Poll(); ++i) {
      std::smatch m;
      const std::string out = ReadAll(log_);
      if (std::regex_search(out, m, url)) return std::stoi(m[1]);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return -1;
  }
  Subprocess& process() { return *process_; }
  std::string log() const { return ReadAll(log_); }

 private:
  std::string log_;
  std::optional<Subprocess> process_;
};

// A TCP connection from `source` (a loopback address) to 127.0.0.1:port;
// -1 if it cannot connect.
int ConnectFrom(const std::string& source, int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in from{};
  from.sin_family = AF_INET;
  inet_pton(AF_INET, source.c_str(), &from.sin_addr);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(port));
  inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&from), sizeof(from)) != 0 ||
      ::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof(to)) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Whether the server has closed `fd`, without waiting or reading: it sends
// a slow client nothing before it closes, so anything to read is the end.
bool ClosedByServer(int fd) {
  pollfd p{fd, POLLIN | POLLRDHUP, 0};
  return ::poll(&p, 1, 0) > 0 && p.revents != 0;
}

struct Answer {
  int status = 0;  // 0: no answer
  std::string body;
};

// GET `path` over plain HTTP from `source`, with `headers` ("Name: value\r\n"
// each); waits at most 30 s for the answer (bounded, not a timing check).
Answer GetFrom(const std::string& source, int port, const std::string& path,
               const std::string& headers = "") {
  Answer a;
  const int fd = ConnectFrom(source, port);
  if (fd < 0) return a;
  const std::string request =
      "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + headers + "Connection: close\r\n\r\n";
  (void)!::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::string got;
  char buf[4096];
  const auto until = Clock::now() + std::chrono::seconds(30);
  while (Clock::now() < until) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) continue;
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) break;
    got.append(buf, static_cast<size_t>(n));
  }
  ::close(fd);
  std::smatch m;
  if (std::regex_search(got, m, std::regex("^HTTP/1\\.1 (\\d{3})"))) a.status = std::stoi(m[1]);
  const size_t body = got.find("\r\n\r\n");
  if (body != std::string::npos) a.body = got.substr(body + 4);
  return a;
}

// Slow clients: each connection sent `opening`, then one `trickle` every
// 300 ms until the server closes it.
class SlowClients {
 public:
  SlowClients(const std::vector<std::string>& sources, int port, std::string opening,
              std::string trickle)
      : trickle_(std::move(trickle)) {
    for (const std::string& source : sources) {
      const int fd = ConnectFrom(source, port);
      if (fd < 0) continue;
      (void)!::send(fd, opening.data(), opening.size(), MSG_NOSIGNAL);
      fds_.push_back(fd);
    }
    thread_ = std::thread([this] {
      while (!stop_) {
        for (int fd : fds_) {
          if (!ClosedByServer(fd))
            (void)!::send(fd, trickle_.data(), trickle_.size(), MSG_NOSIGNAL);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(300));
      }
    });
  }
  ~SlowClients() {
    stop_ = true;
    thread_.join();
    for (int fd : fds_) ::close(fd);
  }
  size_t connected() const { return fds_.size(); }
  // How many the server has closed, now.
  size_t closed() const {
    size_t n = 0;
    for (int fd : fds_) n += ClosedByServer(fd);
    return n;
  }
  // Waits up to `seconds` for the server to close them all.
  bool AllClosedWithin(int seconds) {
    for (int i = 0; i < seconds * 10 && closed() < connected(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return closed() == connected();
  }

 private:
  std::string trickle_;
  std::vector<int> fds_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

std::vector<std::string> Addresses(const std::string& prefix, int first, int count) {
  std::vector<std::string> out;
  for (int i = 0; i < count; ++i) out.push_back(prefix + std::to_string(first + i));
  return out;
}

constexpr int kSlow = 200;
// Every slow connection is closed within the head deadline (5 s) of its
// accept; 30 s leaves room for a loaded machine and is only a bound.
constexpr int kCloseBoundS = 30;
const std::string kOpening = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n";
const std::string kHeaderLine = "X-Slow: 1\r\n";

class ServeAttackTest : public ::testing::Test {
 protected:
  testing::TempDir dir_{"serve_attack"};
};

// GIVEN 200 connections from one address trickling header lines
// WHEN  a client from another address asks for a page
// THEN  it is answered while the slow ones the server let in are still
//       open, the rest were refused at once (16 per client), and every slow
//       connection is closed although each keeps sending.
TEST_F(ServeAttackTest, SlowConnectionsFromOneAddressAreCappedAndCut) {
  const std::string db = MakeArchive(dir_, "a.db", "LOT-A");
  Serve serve({"--db", db, "--listen", "127.0.0.1:0"}, dir_.path("serve.log"));
  const int port = serve.Started();
  ASSERT_GT(port, 0) << serve.log();
  SlowClients slow(std::vector<std::string>(kSlow, "127.0.0.2"), port, kOpening, kHeaderLine);
  ASSERT_EQ(slow.connected(), static_cast<size_t>(kSlow));
  const Answer page = GetFrom("127.0.0.1", port, "/api/lots");
  const size_t open_when_answered = kSlow - slow.closed();
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.body.find("LOT-A"), std::string::npos) << page.body;
  EXPECT_GT(open_when_answered, 0u) << "the answer came only after every slow connection was cut";
  EXPECT_LE(open_when_answered, 16u) << "more than 16 connections of one client were let in";
  EXPECT_TRUE(slow.AllClosedWithin(kCloseBoundS)) << slow.closed() << " of " << kSlow << " closed";
  EXPECT_EQ(serve.process().Stop(10), 0);
  EXPECT_NE(serve.log().find("client 127.0.0.2: "), std::string::npos) << serve.log();
}

// GIVEN 200 connections from 200 addresses (no per-client cap applies)
//       trickling header lines
// WHEN  a client asks for a page
// THEN  it is answered while (nearly) all of them are still open: none holds
//       a worker; each of them is closed at its deadline although it keeps
//       sending.
TEST_F(ServeAttackTest, SlowConnectionsFromManyAddressesHoldNoWorker) {
  const std::string db = MakeArchive(dir_, "a.db", "LOT-A");
  Serve serve({"--db", db, "--listen", "127.0.0.1:0"}, dir_.path("serve.log"));
  const int port = serve.Started();
  ASSERT_GT(port, 0) << serve.log();
  SlowClients slow(Addresses("127.0.1.", 1, kSlow), port, kOpening, kHeaderLine);
  ASSERT_EQ(slow.connected(), static_cast<size_t>(kSlow));
  const Answer page = GetFrom("127.0.0.1", port, "/api/lots");
  const size_t open_when_answered = kSlow - slow.closed();
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.body.find("LOT-A"), std::string::npos) << page.body;
  // More than the 32 workers were open: the answer did not wait for them.
  EXPECT_GT(open_when_answered, 32u);
  EXPECT_TRUE(slow.AllClosedWithin(kCloseBoundS)) << slow.closed() << " of " << kSlow << " closed";
  EXPECT_EQ(serve.process().Stop(10), 0);
}

// GIVEN a TLS server and 200 connections from 200 addresses that open a TLS
//       handshake record and never finish it (a byte at a time)
// WHEN  a TLS client asks for a page with the right token
// THEN  it is answered, and every slow handshake is cut.
TEST_F(ServeAttackTest, SlowTlsHandshakesAreCut) {
  const std::string db = MakeArchive(dir_, "a.db", "LOT-A");
  const std::string cert = dir_.path("cert.pem"), key = dir_.path("key.pem");
  const auto made = testing::RunCommand(
      "openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 2 -subj "
      "/CN=127.0.0.1 -addext subjectAltName=IP:127.0.0.1 -keyout " +
      key + " -out " + cert + " 2>&1");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const std::string token = "slow-tls-token-0123456789";
  Serve serve({"--db", db, "--listen", "127.0.0.1:0", "--tls-cert", cert, "--tls-key", key,
               "--token", token},
              dir_.path("serve.log"));
  const int port = serve.Started();
  ASSERT_GT(port, 0) << serve.log();
  // A handshake record announcing 16 KiB, then a byte of it at a time.
  const std::string record_head("\x16\x03\x01\x40\x00", 5);
  SlowClients slow(Addresses("127.0.2.", 1, kSlow), port, record_head, std::string(1, '\x01'));
  ASSERT_EQ(slow.connected(), static_cast<size_t>(kSlow));
  httplib::SSLClient client("127.0.0.1", port);
  client.set_ca_cert_path(cert.c_str());
  client.enable_server_certificate_verification(true);
  client.set_read_timeout(30, 0);
  auto page = client.Get("/api/lots", {{"Authorization", "Bearer " + token}});
  const size_t open_when_answered = kSlow - slow.closed();
  ASSERT_TRUE(page) << httplib::to_string(page.error());
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("LOT-A"), std::string::npos);
  EXPECT_GT(open_when_answered, 32u);
  EXPECT_TRUE(slow.AllClosedWithin(kCloseBoundS)) << slow.closed() << " of " << kSlow << " closed";
  EXPECT_EQ(serve.process().Stop(10), 0);
  EXPECT_NE(serve.log().find("client 127.0.2.1: 1 connection closed without a complete request "
                             "in time"),
            std::string::npos)
      << serve.log();
}

// Sums the counts of `what` ("wrong token", ...) on the log's lines about `client`.
long CountInLog(const std::string& log, const std::string& client, const std::string& what) {
  long sum = 0;
  std::istringstream lines(log);
  std::string line;
  const std::regex count("(\\d+) " + what);
  while (std::getline(lines, line)) {
    if (line.find("client " + client + ": ") == std::string::npos) continue;
    std::smatch m;
    if (std::regex_search(line, m, count)) sum += std::stol(m[1]);
  }
  return sum;
}

// GIVEN a server with a token
// WHEN  one address sends 300 wrong tokens as fast as it can
// THEN  only a handful are answered as wrong (401: checked), the rest are
//       refused (429) without being checked; another address is served with
//       the right token meanwhile and gets a plain 401 for a wrong one; the
//       log names the address and the counts, which add up to the attempts,
//       and no token.
TEST_F(ServeAttackTest, TokenGuessingIsThrottledAndLogged) {
  const std::string db = MakeArchive(dir_, "a.db", "LOT-A");
  const std::string token_file = dir_.path("token");
  Serve serve({"--db", db, "--listen", "127.0.0.1:0", "--new-token", "--token-file", token_file},
              dir_.path("serve.log"));
  const int port = serve.Started();
  ASSERT_GT(port, 0) << serve.log();
  std::string token = ReadAll(token_file);
  token = token.substr(0, token.find('\n'));
  ASSERT_EQ(token.size(), 43u);

  constexpr int kAttempts = 300;
  int checked = 0, refused = 0, other = 0;
  const auto start = Clock::now();
  for (int i = 0; i < kAttempts; ++i) {
    const Answer a =
        GetFrom("127.0.0.3", port, "/api/lots?token=guess-" + std::to_string(i) + "-abcdefghijkl");
    (a.status == 401 ? checked : a.status == 429 ? refused : other)++;
  }
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  // Right now, the right token from the guessing address is refused too: it
  // is not looked at while the address backs off.
  // (Unless its back-off ended in the instant since its last attempt: then
  // it is served, which clears its count.)
  const Answer blocked =
      GetFrom("127.0.0.3", port, "/api/lots", "Authorization: Bearer " + token + "\r\n");
  EXPECT_TRUE(blocked.status == 429 || blocked.status == 200) << blocked.status;
  // Another address: served with the right token, a plain 401 for a wrong one.
  const Answer legit =
      GetFrom("127.0.0.4", port, "/api/lots", "Authorization: Bearer " + token + "\r\n");
  EXPECT_EQ(legit.status, 200);
  EXPECT_NE(legit.body.find("LOT-A"), std::string::npos);
  const Answer typo = GetFrom("127.0.0.4", port, "/api/lots?token=not-the-right-one-at-all");
  EXPECT_EQ(typo.status, 401);

  // 5 free wrong tokens, then one per back-off, which doubles from 1 s: over
  // `elapsed_s` at most 5 + 1 + log2(1 + elapsed_s) tokens can be checked
  // (one more for rounding), however fast the attempts come.
  const int bound = 5 + 2 + static_cast<int>(std::log2(1 + elapsed_s));
  std::printf("guessing: %d attempts in %.1f s: %d checked (401), %d refused (429)\n", kAttempts,
              elapsed_s, checked, refused);
  EXPECT_EQ(other, 0);
  EXPECT_LE(checked, bound);
  EXPECT_GE(checked, 5);
  EXPECT_EQ(checked + refused, kAttempts);

  EXPECT_EQ(serve.process().Stop(10), 0);
  const std::string log = serve.log();
  EXPECT_EQ(CountInLog(log, "127.0.0.3", "wrong tokens?"), checked) << log;
  EXPECT_EQ(CountInLog(log, "127.0.0.3", "requests? refused while it backs off"),
            refused + (blocked.status == 429 ? 1 : 0))
      << log;
  EXPECT_EQ(CountInLog(log, "127.0.0.4", "wrong tokens?"), 1) << log;
  EXPECT_EQ(log.find("guess-"), std::string::npos) << log;
  EXPECT_EQ(log.find(token), std::string::npos) << "the token is in the log";
  EXPECT_EQ(log.find("not-the-right-one"), std::string::npos) << log;
}

// GIVEN a server on a port
// WHEN  a second one is started on the same port (another archive)
// THEN  it exits with an error and one line naming the address, and every
//       request goes on to the first one.
TEST_F(ServeAttackTest, ASecondServerOnAPortInUseFails) {
  Serve first({"--db", MakeArchive(dir_, "a.db", "LOT-A"), "--listen", "127.0.0.1:0"},
              dir_.path("first.log"));
  const int port = first.Started();
  ASSERT_GT(port, 0) << first.log();
  Serve second(
      {"--db", MakeArchive(dir_, "b.db", "LOT-B"), "--listen", "127.0.0.1:" + std::to_string(port)},
      dir_.path("second.log"));
  const std::optional<int> code = second.process().Wait(20);
  ASSERT_TRUE(code.has_value()) << "the second server is still running";
  EXPECT_EQ(*code, 1);
  const std::string said = second.log();
  EXPECT_EQ(std::count(said.begin(), said.end(), '\n'), 1) << said;
  EXPECT_NE(said.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << said;
  EXPECT_NE(said.find("in use"), std::string::npos) << said;
  for (int i = 0; i < 20; ++i) {
    const Answer a = GetFrom("127.0.0.1", port, "/api/lots");
    EXPECT_EQ(a.status, 200);
    EXPECT_NE(a.body.find("LOT-A"), std::string::npos) << a.body;
    EXPECT_EQ(a.body.find("LOT-B"), std::string::npos) << a.body;
  }
  EXPECT_EQ(first.process().Stop(10), 0);
}

}  // namespace
}  // namespace imuqual::web
