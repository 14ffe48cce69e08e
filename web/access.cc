#include "web/access.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "common/keys.h"

namespace imuqual::web {

std::string ClientKey(const std::string& ip) {
  in_addr v4{};
  if (inet_pton(AF_INET, ip.c_str(), &v4) == 1) return ip;
  in6_addr v6{};
  if (inet_pton(AF_INET6, ip.c_str(), &v6) != 1) return ip;
  char text[INET6_ADDRSTRLEN] = {};
  if (IN6_IS_ADDR_V4MAPPED(&v6)) {
    std::memcpy(&v4, v6.s6_addr + 12, 4);
    return inet_ntop(AF_INET, &v4, text, sizeof(text)) ? text : ip;
  }
  std::fill(v6.s6_addr + 8, v6.s6_addr + 16, 0);
  return inet_ntop(AF_INET6, &v6, text, sizeof(text)) ? std::string(text) + "/64" : ip;
}

Status CheckToken(const std::string& token) {
  const bool plain = token.find_first_not_of(
                         "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-._~+/=") ==
                     std::string::npos;
  if (!plain || token.size() < 12) {
    return Status::InvalidArgument(
        "serve: the token must be at least 12 characters of letters, digits and -._~+/= "
        "(it travels in a header, a URL and a cookie)");
  }
  return Status::Ok();
}

Result<std::string> NewToken() {
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  unsigned char bytes[32];
  randombytes_buf(bytes, sizeof(bytes));
  constexpr int kVariant = sodium_base64_VARIANT_URLSAFE_NO_PADDING;
  std::string text(sodium_base64_encoded_len(sizeof(bytes), kVariant), '\0');
  sodium_bin2base64(text.data(), text.size(), bytes, sizeof(bytes), kVariant);
  sodium_memzero(bytes, sizeof(bytes));
  text.resize(std::strlen(text.c_str()));  // without the terminating NUL
  return text;
}

Status WriteNewTokenFile(const std::string& path, const std::string& token) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    if (errno == EEXIST) {
      return Status::InvalidArgument("serve: --new-token: " + path +
                                     " exists already (a token file is never overwritten: "
                                     "remove it, or serve with it without --new-token)");
    }
    return Status::IoError("serve: --new-token: cannot create " + path + ": " +
                           std::strerror(errno));
  }
  (void)::fchmod(fd, 0600);  // owner-only whatever the umask said
  const std::string text = token + "\n";
  size_t put = 0;
  while (put < text.size()) {
    const ssize_t n = ::write(fd, text.data() + put, text.size() - put);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      ::unlink(path.c_str());
      return Status::IoError("serve: --new-token: cannot write " + path + ": " + why);
    }
    put += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(path.c_str());
    return Status::IoError("serve: --new-token: cannot write " + path + ": " + why);
  }
  return Status::Ok();
}

// --- TokenThrottle ---

void TokenThrottle::Forget(double now_s) {
  for (auto it = clients_.begin(); it != clients_.end();) {
    const bool quiet = now_s - it->second.last_failure_s > kForgetS;
    it = quiet && now_s >= it->second.wait_until_s ? clients_.erase(it) : std::next(it);
  }
  if (clients_.size() < kMaxClients) return;
  auto oldest =
      std::min_element(clients_.begin(), clients_.end(), [](const auto& a, const auto& b) {
        return a.second.last_failure_s < b.second.last_failure_s;
      });
  clients_.erase(oldest);
}

double TokenThrottle::WaitS(const std::string& client, double now_s) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = clients_.find(client);
  if (it == clients_.end() || now_s >= it->second.wait_until_s) return 0;
  return it->second.wait_until_s - now_s;
}

double TokenThrottle::Failed(const std::string& client, double now_s) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = clients_.find(client);
  if (it == clients_.end()) {
    Forget(now_s);
    it = clients_.emplace(client, Entry{}).first;
  }
  Entry& e = it->second;
  ++e.failures;
  e.last_failure_s = now_s;
  if (e.failures <= kFreeFailures) return 0;
  // kFirstBackoffS after the first failure past the free ones, doubled with
  // each one after it (the exponent is capped before pow can overflow).
  const int doublings = std::min(e.failures - kFreeFailures - 1, 30);
  const double wait_s = std::min(kMaxBackoffS, kFirstBackoffS * std::pow(2.0, doublings));
  e.wait_until_s = now_s + wait_s;
  return wait_s;
}

void TokenThrottle::Succeeded(const std::string& client) {
  std::lock_guard<std::mutex> lock(mu_);
  clients_.erase(client);
}

int TokenThrottle::Failures(const std::string& client) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = clients_.find(client);
  return it == clients_.end() ? 0 : it->second.failures;
}

// --- ClientLog ---

ClientLog::ClientLog(std::function<void(const std::string&)> sink) : sink_(std::move(sink)) {}

void ClientLog::Note(const std::string& client, Event event, double now_s) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = clients_.find(client);
  if (it == clients_.end()) {
    if (clients_.size() >= kMaxClients) {
      // The client quiet longest goes, with its line if it has counts.
      auto oldest =
          std::min_element(clients_.begin(), clients_.end(), [](const auto& a, const auto& b) {
            return a.second.last_event_s < b.second.last_event_s;
          });
      Emit(oldest->first, &oldest->second, now_s);
      clients_.erase(oldest);
    }
    it = clients_.emplace(client, Entry{}).first;
  }
  Entry& e = it->second;
  bool had_counts = false;
  for (uint64_t c : e.counts) had_counts |= c > 0;
  if (!had_counts) e.last_event_s = now_s;  // the first event of this line
  ++e.counts[static_cast<int>(event)];
  if (now_s - e.last_line_s >= kPeriodS) Emit(client, &e, now_s);
}

void ClientLog::Flush(double now_s, bool all) {
  std::lock_guard<std::mutex> lock(mu_);
  for (auto it = clients_.begin(); it != clients_.end();) {
    if (all || now_s - it->second.last_line_s >= kPeriodS) Emit(it->first, &it->second, now_s);
    bool empty = true;
    for (uint64_t c : it->second.counts) empty &= c == 0;
    // A client quiet for a whole period starts afresh (its next event is logged at once).
    it = empty && now_s - it->second.last_line_s >= kPeriodS ? clients_.erase(it) : std::next(it);
  }
}

void ClientLog::Emit(const std::string& client, Entry* e, double now_s) {
  static constexpr const char* kWords[kEvents][2] = {
      {"wrong token", "wrong tokens"},
      {"request refused while it backs off (429)", "requests refused while it backs off (429)"},
      {"connection refused at once (too many open)", "connections refused at once (too many open)"},
      {"connection closed without a complete request in time",
       "connections closed without a complete request in time"},
      {"TLS handshake failed", "TLS handshakes failed"},
  };
  std::string parts;
  uint64_t total = 0;
  for (int i = 0; i < kEvents; ++i) {
    if (e->counts[i] == 0) continue;
    if (!parts.empty()) parts += ", ";
    parts += std::to_string(e->counts[i]) + " " + kWords[i][e->counts[i] == 1 ? 0 : 1];
    total += e->counts[i];
    e->counts[i] = 0;
  }
  if (total == 0) return;
  const double span_s = now_s - e->last_event_s;
  if (total > 1 && span_s >= 1) parts += " within " + std::to_string(std::lround(span_s)) + " s";
  e->last_line_s = now_s;
  sink_("serve: client " + client + ": " + parts);
}

}  // namespace imuqual::web
