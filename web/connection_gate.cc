#include "web/connection_gate.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <openssl/err.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "common/clock.h"

namespace imuqual::web {
namespace {

// One connection. The loop thread owns it while it waits for its head; a
// worker owns it from dispatch to close.
struct Conn {
  int fd = -1;
  SSL* ssl = nullptr;     // with TLS
  std::string buf;        // bytes received: the request head, and anything after it
  double deadline_s = 0;  // accept + head_deadline_s
  short want = POLLIN;    // what the next step waits for
  bool handshake_done = false;
  bool first_byte_seen = false;
  std::string ip, local_ip, client;
  int port = 0, local_port = 0;
};

// Address and port of a socket address, as text.
void AddressText(const sockaddr_storage& a, std::string* ip, int* port) {
  char text[INET6_ADDRSTRLEN] = {};
  if (a.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
    inet_ntop(AF_INET, &v4->sin_addr, text, sizeof(text));
    *port = ntohs(v4->sin_port);
  } else if (a.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
    inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof(text));
    *port = ntohs(v6->sin6_port);
  }
  *ip = text;
}

int Millis(double s) {
  if (s <= 0) return 0;
  return static_cast<int>(std::min(s * 1000.0 + 1, 1e9));
}

// Waits up to timeout_ms for `events` on fd (or a hang-up or error, which
// the next read or write reports). False on timeout.
bool WaitFor(int fd, short events, int timeout_ms) {
  pollfd p{fd, events, 0};
  const double until_s = MonotonicSeconds() + timeout_ms / 1000.0;
  for (;;) {
    const int n = ::poll(&p, 1, timeout_ms);
    if (n > 0) return true;
    if (n == 0) return false;
    if (errno != EINTR) return true;  // let the read or write say what is wrong
    timeout_ms = Millis(until_s - MonotonicSeconds());
  }
}

// The stream a worker answers on: the head the loop read first, then the
// socket (TLS or plain, non-blocking, waits bounded by the timeouts).
// cpp-httplib expects write() to write everything (it ignores short writes
// of the header block), so write() returns only when all is written or the
// connection failed.
class GateStream final : public httplib::Stream {
 public:
  GateStream(const Conn& c, double read_timeout_s, double write_timeout_s)
      : c_(c), read_ms_(Millis(read_timeout_s)), write_ms_(Millis(write_timeout_s)) {}

  bool is_readable() const override {
    if (pos_ < c_.buf.size()) return true;
    if (c_.ssl != nullptr && SSL_pending(c_.ssl) > 0) return true;
    return WaitFor(c_.fd, POLLIN, read_ms_);
  }
  bool is_writable() const override { return WaitFor(c_.fd, POLLOUT, write_ms_); }

  ssize_t read(char* ptr, size_t size) override {
    if (pos_ < c_.buf.size()) {
      const size_t n = std::min(size, c_.buf.size() - pos_);
      std::memcpy(ptr, c_.buf.data() + pos_, n);
      pos_ += n;
      return static_cast<ssize_t>(n);
    }
    const int chunk = static_cast<int>(std::min<size_t>(size, 1 << 20));
    for (;;) {
      if (c_.ssl != nullptr) {
        ERR_clear_error();
        const int n = SSL_read(c_.ssl, ptr, chunk);
        if (n > 0) return n;
        const int err = SSL_get_error(c_.ssl, n);
        if (err == SSL_ERROR_ZERO_RETURN) return 0;
        if (err == SSL_ERROR_WANT_READ && WaitFor(c_.fd, POLLIN, read_ms_)) continue;
        if (err == SSL_ERROR_WANT_WRITE && WaitFor(c_.fd, POLLOUT, write_ms_)) continue;
        return -1;
      }
      const ssize_t n = ::recv(c_.fd, ptr, static_cast<size_t>(chunk), 0);
      if (n >= 0) return n;
      if (errno == EINTR) continue;
      if ((errno == EAGAIN || errno == EWOULDBLOCK) && WaitFor(c_.fd, POLLIN, read_ms_)) continue;
      return -1;
    }
  }

  ssize_t write(const char* ptr, size_t size) override {
    size_t done = 0;
    while (done < size) {
      const size_t left = std::min<size_t>(size - done, 1 << 20);
      if (c_.ssl != nullptr) {
        ERR_clear_error();
        const int n = SSL_write(c_.ssl, ptr + done, static_cast<int>(left));
        if (n > 0) {
          done += static_cast<size_t>(n);
          continue;
        }
        const int err = SSL_get_error(c_.ssl, n);
        if (err == SSL_ERROR_WANT_WRITE && WaitFor(c_.fd, POLLOUT, write_ms_)) continue;
        if (err == SSL_ERROR_WANT_READ && WaitFor(c_.fd, POLLIN, write_ms_)) continue;
        return -1;
      }
      const ssize_t n = ::send(c_.fd, ptr + done, left, MSG_NOSIGNAL);
      if (n > 0) {
        done += static_cast<size_t>(n);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) && WaitFor(c_.fd, POLLOUT, write_ms_))
        continue;
      return -1;
    }
    return static_cast<ssize_t>(size);
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.ip;
    port = c_.port;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.local_ip;
    port = c_.local_port;
  }
  socket_t socket() const override { return c_.fd; }

 private:
  const Conn& c_;
  const int read_ms_;
  const int write_ms_;
  size_t pos_ = 0;
};

// What the loop does with a waiting connection after a step.
enum class Next { kWait, kDispatch, kClose };

// Best effort: a short answer on a socket that may refuse it.
void SendPlain(int fd, const std::string& text) {
  (void)!::send(fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
}

std::string PlainResponse(int status, const char* reason, const std::string& body) {
  return "HTTP/1.1 " + std::to_string(status) + " " + reason +
         "\r\nContent-Type: text/plain; charset=utf-8\r\nConnection: close\r\nContent-Length: " +
         std::to_string(body.size()) + "\r\n\r\n" + body;
}

}  // namespace

struct ConnectionGate::Impl {
  GateOptions o;
  ClientLog* log = nullptr;
  int listen_fd = -1;
  int wake_fd = -1;
  int port = 0;
  std::atomic<bool> stopping{false};

  // The loop thread's: connections still sending their head, oldest first.
  std::vector<std::unique_ptr<Conn>> waiting;
  double accept_paused_until_s = 0;  // out of file descriptors: accept again later

  // Shared with the workers.
  std::mutex mu;
  std::map<std::string, int> open_per_client;
  size_t open_total = 0;
  std::set<int> handed_fds;  // connections queued or being answered (shut down on stop)
  std::deque<std::unique_ptr<Conn>> queue;
  bool queue_closed = false;
  std::condition_variable queue_cv;

  std::atomic<uint64_t> accepted{0}, refused_over_cap{0}, dropped_waiting{0}, closed_at_deadline{0},
      tls_failed{0}, dispatched{0};

  void Note(const Conn& c, ClientLog::Event e) {
    if (log != nullptr) log->Note(c.client, e, MonotonicSeconds());
  }

  // Closes a connection that was counted open (any thread).
  void Close(std::unique_ptr<Conn> c) {
    if (c->ssl != nullptr) {
      SSL_shutdown(c->ssl);  // one non-blocking try at close_notify
      SSL_free(c->ssl);
      ERR_clear_error();
    }
    {
      // Out of handed_fds before the descriptor is closed, so that Stop never
      // shuts down a number the kernel has given to a newer connection.
      std::lock_guard<std::mutex> lock(mu);
      handed_fds.erase(c->fd);
      auto it = open_per_client.find(c->client);
      if (it != open_per_client.end() && --it->second <= 0) open_per_client.erase(it);
      --open_total;
    }
    ::close(c->fd);
  }

  void AcceptAll(double now_s) {
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(mu);
        if (open_total >= o.max_open) return;
      }
      sockaddr_storage peer{};
      socklen_t len = sizeof(peer);
      const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&peer), &len,
                               SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) {
        if (errno == EINTR || errno == ECONNABORTED) continue;
        if (errno == EMFILE || errno == ENFILE) {
          // Out of descriptors: make room from the longest waiting, else pause.
          if (!waiting.empty()) {
            DropOldestWaiting();
            continue;
          }
          accept_paused_until_s = now_s + 0.1;
        }
        return;  // EAGAIN: all accepted
      }
      auto c = std::make_unique<Conn>();
      c->fd = fd;
      AddressText(peer, &c->ip, &c->port);
      sockaddr_storage local{};
      len = sizeof(local);
      if (::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &len) == 0)
        AddressText(local, &c->local_ip, &c->local_port);
      c->client = ClientKey(c->ip);
      ++accepted;
      bool over_cap = false;
      {
        std::lock_guard<std::mutex> lock(mu);
        int& open = open_per_client[c->client];
        over_cap = open >= o.max_per_client;
        if (over_cap) {
          if (open == 0) open_per_client.erase(c->client);
        } else {
          ++open;
          ++open_total;
        }
      }
      if (over_cap) {
        ++refused_over_cap;
        Note(*c, ClientLog::Event::kOverConnectionCap);
        ::close(fd);
        continue;
      }
      if (waiting.size() >= o.max_waiting) DropOldestWaiting();
      c->deadline_s = now_s + o.head_deadline_s;
      if (o.tls != nullptr) {
        c->ssl = SSL_new(o.tls);
        if (c->ssl == nullptr || SSL_set_fd(c->ssl, fd) != 1) {
          ++tls_failed;
          Close(std::move(c));
          continue;
        }
        SSL_set_accept_state(c->ssl);
      }
      waiting.push_back(std::move(c));
    }
  }

  void DropOldestWaiting() {
    if (waiting.empty()) return;
    auto oldest = std::min_element(
        waiting.begin(), waiting.end(),
        [](const auto& a, const auto& b) { return a && (!b || a->deadline_s < b->deadline_s); });
    if (!*oldest) return;
    ++dropped_waiting;
    Note(**oldest, ClientLog::Event::kHeadDeadline);
    Close(std::move(*oldest));
    waiting.erase(oldest);
  }

  // Advances a waiting connection as far as its socket allows.
  Next Step(Conn& c) {
    if (c.ssl != nullptr && !c.handshake_done) {
      if (!c.first_byte_seen) {
        // A TLS connection starts with a handshake record (0x16); an upper
        // case letter is an HTTP method: someone typed http:// for https://.
        unsigned char first = 0;
        const ssize_t n = ::recv(c.fd, &first, 1, MSG_PEEK);
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) {
          c.want = POLLIN;
          return Next::kWait;
        }
        if (n <= 0) return Next::kClose;
        c.first_byte_seen = true;
        if (first != 0x16) {
          ++tls_failed;
          Note(c, ClientLog::Event::kTlsFailed);
          if (first >= 'A' && first <= 'Z') {
            SendPlain(c.fd, PlainResponse(400, "Bad Request",
                                          "This server speaks HTTPS only: open https:// instead "
                                          "of http:// (same address and port).\n"));
          }
          return Next::kClose;
        }
      }
      ERR_clear_error();
      const int r = SSL_accept(c.ssl);
      if (r != 1) {
        const int err = SSL_get_error(c.ssl, r);
        if (err == SSL_ERROR_WANT_READ || err == SSL_ERROR_WANT_WRITE) {
          c.want = err == SSL_ERROR_WANT_READ ? POLLIN : POLLOUT;
          return Next::kWait;
        }
        ++tls_failed;
        Note(c, ClientLog::Event::kTlsFailed);
        return Next::kClose;
      }
      c.handshake_done = true;
    }
    char chunk[4096];
    for (;;) {
      const size_t room = ConnectionGate::kMaxHeadBytes + 4 - c.buf.size();
      const size_t ask = std::min(sizeof(chunk), room);
      ssize_t n;
      if (c.ssl != nullptr) {
        ERR_clear_error();
        const int r = SSL_read(c.ssl, chunk, static_cast<int>(ask));
        if (r <= 0) {
          const int err = SSL_get_error(c.ssl, r);
          if (err == SSL_ERROR_WANT_READ || err == SSL_ERROR_WANT_WRITE) {
            c.want = err == SSL_ERROR_WANT_READ ? POLLIN : POLLOUT;
            return Next::kWait;
          }
          return Next::kClose;
        }
        n = r;
      } else {
        n = ::recv(c.fd, chunk, ask, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
          c.want = POLLIN;
          return Next::kWait;
        }
        if (n <= 0) return Next::kClose;
      }
      const size_t from = c.buf.size() < 3 ? 0 : c.buf.size() - 3;
      c.buf.append(chunk, static_cast<size_t>(n));
      const size_t end = c.buf.find("\r\n\r\n", from);
      if (end != std::string::npos && end + 4 <= ConnectionGate::kMaxHeadBytes)
        return Next::kDispatch;
      if (c.buf.size() > ConnectionGate::kMaxHeadBytes) {
        if (c.ssl == nullptr) {
          SendPlain(c.fd, PlainResponse(431, "Request Header Fields Too Large",
                                        "the request head is too long\n"));
        }
        return Next::kClose;
      }
    }
  }

  void Dispatch(std::unique_ptr<Conn> c) {
    ++dispatched;
    std::lock_guard<std::mutex> lock(mu);
    handed_fds.insert(c->fd);
    queue.push_back(std::move(c));
    queue_cv.notify_one();
  }

  void Work(const Handler& handler) {
    for (;;) {
      std::unique_ptr<Conn> c;
      {
        std::unique_lock<std::mutex> lock(mu);
        queue_cv.wait(lock, [&] { return !queue.empty() || queue_closed; });
        if (queue.empty()) return;
        c = std::move(queue.front());
        queue.pop_front();
      }
      if (!stopping) {
        GateStream stream(*c, o.read_timeout_s, o.write_timeout_s);
        try {
          handler(stream);
        } catch (...) {
          // cpp-httplib answers a handler's exception with 500 itself; anything
          // past it costs this connection only, never the worker.
        }
      }
      Close(std::move(c));
    }
  }

  void Loop(const std::function<void()>& tick) {
    double last_tick_s = MonotonicSeconds();
    std::vector<pollfd> fds;
    while (!stopping) {
      double now_s = MonotonicSeconds();
      fds.clear();
      fds.push_back({wake_fd, POLLIN, 0});
      bool accepting = now_s >= accept_paused_until_s;
      {
        std::lock_guard<std::mutex> lock(mu);
        accepting = accepting && open_total < o.max_open;
      }
      fds.push_back({accepting ? listen_fd : -1, POLLIN, 0});
      double wake_s = std::min(last_tick_s + 1.0, accepting ? 1e300 : accept_paused_until_s);
      for (const auto& c : waiting) {
        fds.push_back({c->fd, c->want, 0});
        wake_s = std::min(wake_s, c->deadline_s);
      }
      // Without room to accept (max_open), a closing worker does not wake
      // the loop: look again at least every 50 ms.
      if (!accepting) wake_s = std::min(wake_s, now_s + 0.05);
      const int n = ::poll(fds.data(), fds.size(), Millis(wake_s - now_s));
      if (n < 0 && errno != EINTR) break;
      now_s = MonotonicSeconds();
      if (fds[0].revents != 0) {
        uint64_t ignored;
        (void)!::read(wake_fd, &ignored, sizeof(ignored));
      }
      const size_t polled = fds.size() - 2;  // the waiting connections polled this round
      for (size_t i = 0; i < polled; ++i) {
        if (fds[i + 2].revents == 0) continue;
        std::unique_ptr<Conn>& c = waiting[i];
        switch (Step(*c)) {
          case Next::kWait:
            break;
          case Next::kDispatch:
            Dispatch(std::move(c));
            break;
          case Next::kClose:
            Close(std::move(c));
            break;
        }
      }
      for (auto& c : waiting) {
        if (c && now_s >= c->deadline_s) {
          ++closed_at_deadline;
          Note(*c, ClientLog::Event::kHeadDeadline);
          Close(std::move(c));
        }
      }
      waiting.erase(std::remove(waiting.begin(), waiting.end(), nullptr), waiting.end());
      if (fds[1].revents != 0) AcceptAll(now_s);
      if (now_s - last_tick_s >= 1.0) {
        last_tick_s = now_s;
        if (tick) tick();
      }
    }
    for (auto& c : waiting) Close(std::move(c));
    waiting.clear();
  }
};

ConnectionGate::ConnectionGate(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

ConnectionGate::~ConnectionGate() {
  if (impl_->listen_fd >= 0) ::close(impl_->listen_fd);
  if (impl_->wake_fd >= 0) ::close(impl_->wake_fd);
}

Result<std::unique_ptr<ConnectionGate>> ConnectionGate::Bind(const GateOptions& o, ClientLog* log) {
  const bool v6 = o.host.find(':') != std::string::npos;
  const std::string where = (v6 ? "[" + o.host + "]" : o.host) + ":" + std::to_string(o.port);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const int gai = ::getaddrinfo(o.host.c_str(), std::to_string(o.port).c_str(), &hints, &found);
  if (gai != 0) {
    return Status::InvalidArgument("serve: cannot listen on " + where + ": " + ::gai_strerror(gai));
  }
  int fd = -1;
  int error = 0;
  for (addrinfo* ai = found; ai != nullptr && fd < 0; ai = ai->ai_next) {
    fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai->ai_protocol);
    if (fd < 0) {
      error = errno;
      continue;
    }
    // SO_REUSEADDR lets a restarted server bind while its old connections
    // linger in TIME_WAIT, never beside a listening socket; no SO_REUSEPORT.
    const int yes = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    if (::bind(fd, ai->ai_addr, ai->ai_addrlen) != 0 || ::listen(fd, 128) != 0) {
      error = errno;
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(found);
  if (fd < 0) {
    std::string why = std::strerror(error);
    if (error == EADDRINUSE) {
      why =
          "the port is in use (another server listens there: stop it, or choose another "
          "--listen port)";
    } else if (error == EADDRNOTAVAIL) {
      why = "not an address of this host";
    } else if (error == EACCES) {
      why = "permission denied (ports below 1024 need privileges)";
    }
    return Status::Unavailable("serve: cannot listen on " + where + ": " + why);
  }
  auto impl = std::make_unique<Impl>();
  impl->o = o;
  impl->log = log;
  impl->listen_fd = fd;
  sockaddr_storage bound{};
  socklen_t len = sizeof(bound);
  std::string ignored;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &len) == 0)
    AddressText(bound, &ignored, &impl->port);
  impl->wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (impl->wake_fd < 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    return Status::Unavailable("serve: eventfd: " + why);
  }
  return std::unique_ptr<ConnectionGate>(new ConnectionGate(std::move(impl)));
}

int ConnectionGate::port() const { return impl_->port; }
int ConnectionGate::listen_fd() const { return impl_->listen_fd; }

void ConnectionGate::Run(const Handler& handler, const std::function<void()>& tick) {
  Impl& s = *impl_;
  std::vector<std::thread> workers;
  for (size_t i = 0; i < s.o.workers; ++i) workers.emplace_back([&] { s.Work(handler); });
  s.Loop(tick);
  {
    // Connections being answered end now (a stalled write, an event
    // stream); those queued are closed unanswered.
    std::lock_guard<std::mutex> lock(s.mu);
    s.queue_closed = true;
    for (int fd : s.handed_fds) ::shutdown(fd, SHUT_RDWR);
  }
  s.queue_cv.notify_all();
  for (std::thread& t : workers) t.join();
}

void ConnectionGate::Stop() {
  impl_->stopping = true;
  const uint64_t one = 1;
  (void)!::write(impl_->wake_fd, &one, sizeof(one));
}

ConnectionGate::Counts ConnectionGate::counts() const {
  Counts c;
  c.accepted = impl_->accepted;
  c.refused_over_cap = impl_->refused_over_cap;
  c.dropped_waiting = impl_->dropped_waiting;
  c.closed_at_deadline = impl_->closed_at_deadline;
  c.tls_failed = impl_->tls_failed;
  c.dispatched = impl_->dispatched;
  return c;
}

}  // namespace imuqual::web
