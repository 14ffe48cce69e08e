// Who may read through `imuqual serve`, beyond the comparison of a token:
// acceptable tokens and new ones, the key that per-client limits count by,
// the back-off of clients that guess tokens, and the log of what clients did
// that an operator should know about.
//
// Times are monotonic seconds passed in by the caller (MonotonicSeconds() in
// the server), so that the schedules can be tested without waiting.
#ifndef IMUQUAL_WEB_ACCESS_H_
#define IMUQUAL_WEB_ACCESS_H_

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "common/status.h"

namespace imuqual::web {

// The client that per-client limits count by: an IPv4 address as it is (also
// when it arrives IPv4-mapped, "::ffff:10.0.0.7" -> "10.0.0.7"), an IPv6
// address by its /64 ("2001:db8:0:1::/64": a host picks addresses within its
// /64 at will, so one address per host would be no limit). Text that is not
// an address is returned as is.
std::string ClientKey(const std::string& ip);

// Ok when `token` may be used: at least 12 characters, each of A-Z a-z 0-9
// and -._~+/= (it travels in a header, a URL and a cookie). The error says so.
Status CheckToken(const std::string& token);

// A new token: 32 bytes from libsodium's randombytes_buf (256 bits), as
// base64url without padding (43 characters of A-Z a-z 0-9 - _).
Result<std::string> NewToken();

// Writes "TOKEN\n" to a new file `path` created owner-only (0600, whatever
// the umask). An existing file is never overwritten: the error names it.
Status WriteNewTokenFile(const std::string& path, const std::string& token);

// The back-off of clients (ClientKey) that send wrong tokens. The first
// kFreeFailures wrong tokens are answered as they come (401: typing
// mistakes); each further one makes the client wait kFirstBackoffS, doubled
// with each wrong token after it, at most kMaxBackoffS. While it waits, every
// request of the client is refused (429, Retry-After) without its token
// being looked at, so that guesses made then test nothing. A right token
// clears the client's count; a client is forgotten kForgetS after its last
// wrong token. At most kMaxClients are remembered (the one longest quiet
// goes first). Thread-safe.
class TokenThrottle {
 public:
  static constexpr int kFreeFailures = 5;
  static constexpr double kFirstBackoffS = 1;
  static constexpr double kMaxBackoffS = 300;
  static constexpr double kForgetS = 900;
  static constexpr size_t kMaxClients = 4096;

  // 0 when `client` may present a token now, else the seconds (> 0) it must
  // still wait.
  double WaitS(const std::string& client, double now_s);
  // A wrong token from `client` (one that was allowed to try); returns the
  // wait that starts now (0 while its failures are still free).
  double Failed(const std::string& client, double now_s);
  // A right token from `client`.
  void Succeeded(const std::string& client);
  // Wrong tokens counted for `client` (for tests).
  int Failures(const std::string& client);

 private:
  struct Entry {
    int failures = 0;
    double last_failure_s = 0;
    double wait_until_s = 0;
  };
  void Forget(double now_s);  // with mu_ held
  std::mutex mu_;
  std::map<std::string, Entry> clients_;
};

// What clients did that an operator should know about, one line per client
// at most once per kPeriodS: a client's first event is logged at once, the
// ones after it summed until the period is over, e.g.
//   serve: client 10.0.0.7: 6 wrong tokens, 290 requests refused while it
//   backs off (429) in the last 60 s
// A line names the client (ClientKey) and counts; never a token. Lines go
// to `sink` (LogWarning in the server). Thread-safe; `sink` is called with
// the log's lock held (it must not call back).
class ClientLog {
 public:
  enum class Event {
    kWrongToken,         // a token presented and wrong (401)
    kRefusedBackingOff,  // a request refused while the client backs off (429)
    kOverConnectionCap,  // a connection closed at once: the client had its maximum open
    kHeadDeadline,       // a connection closed: no complete request head in time
    kTlsFailed,          // a TLS handshake failed (or plain HTTP to the TLS port)
  };
  static constexpr double kPeriodS = 60;
  static constexpr size_t kMaxClients = 4096;

  explicit ClientLog(std::function<void(const std::string&)> sink);
  // Counts one event of `client`; logs its line now when its last line is a
  // period old (or it has none).
  void Note(const std::string& client, Event event, double now_s);
  // Logs the lines that are due (a client with counts whose last line is a
  // period old), or, with `all`, every client's counts (on stop).
  void Flush(double now_s, bool all);

 private:
  static constexpr int kEvents = 5;
  struct Entry {
    uint64_t counts[kEvents] = {};
    double last_line_s = -1e300;
    double last_event_s = 0;
  };
  void Emit(const std::string& client, Entry* e, double now_s);  // with mu_ held
  std::function<void(const std::string&)> sink_;
  std::mutex mu_;
  std::map<std::string, Entry> clients_;
};

}  // namespace imuqual::web

#endif  // IMUQUAL_WEB_ACCESS_H_
