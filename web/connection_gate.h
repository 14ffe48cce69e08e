// The front door of `imuqual serve`: its own listening socket and accept loop
// in front of cpp-httplib, so that slow or many connections cannot keep a
// request from being answered.
//
// Why not cpp-httplib's own loop: cpp-httplib 0.11 accepts on one thread and
// hands each socket at once to a pool worker (Server::new_task_queue), which
// then does the TLS handshake (SSLServer) and reads the request head with a
// timeout per read (SO_RCVTIMEO / poll), in a private method that sees the
// socket before any hook does. A client that sends a header line every 2 s
// holds a worker for as long as it likes, and 32 such clients hold them all:
// no deadline can be applied there, and no worker should wait on a client at
// all. It also sets SO_REUSEPORT on the listening socket (a second server on
// the port binds without complaint and the kernel splits connections
// between the two) and listens with a backlog of 5.
//
// The design here:
//   - One loop thread owns the listening socket (SO_REUSEADDR only, so a
//     port in use is an error at Bind, never a second listener; backlog
//     128) and every connection until its request head is complete. It
//     polls non-blocking sockets: a connection that is waiting costs a file
//     descriptor and a small buffer, never a thread.
//   - At accept: a client (ClientKey: an IPv4 address, an IPv6 /64) with
//     max_per_client connections open (waiting, queued or being answered)
//     has the new one closed at once. With max_waiting connections waiting,
//     the one waiting longest is closed to make room (it has had the most
//     time), so a flood cannot lock out newcomers either.
//   - Each connection must complete its TLS handshake (when TLS is on) and
//     its whole request head ("\r\n\r\n", at most kMaxHeadBytes) within
//     head_deadline_s of its accept, however it trickles; past that it is
//     closed. A head too long gets 431 (plain HTTP) and is closed.
//   - A complete head goes to a bounded pool of workers, which answer it with
//     cpp-httplib's request parsing, routing and response writing
//     (Handler: Server::process_request over the Stream given) and close the
//     connection (one request per connection). A worker reads nothing more
//     from the client: a GET has no body; reads past the head, if any, wait
//     at most read_timeout_s. Writes wait at most write_timeout_s for room.
//   - TLS is OpenSSL's (web/tls.h), non-blocking on the loop thread for the
//     handshake and the head, then on the worker. A plain HTTP request sent
//     to the TLS port is answered in plain text with a hint to use https.
// Stop() shuts down every connection (an event stream ends at once), then
// Run() joins the workers and returns.
//
// Events a client causes (refused over its cap, closed at the deadline, a
// failed handshake) are counted in counts() and noted in the ClientLog.
#ifndef IMUQUAL_WEB_CONNECTION_GATE_H_
#define IMUQUAL_WEB_CONNECTION_GATE_H_

#include <httplib.h>
#include <openssl/ssl.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "common/status.h"
#include "web/access.h"

namespace imuqual::web {

struct GateOptions {
  std::string host = "127.0.0.1";  // an address of this host (or localhost, ::, 0.0.0.0)
  int port = 0;                    // 0: any free port
  SSL_CTX* tls = nullptr;          // not owned, outlives the gate; null: plain HTTP
  size_t workers = 32;             // requests answered at once (event streams hold one each)
  double head_deadline_s = 5;      // accept -> TLS handshake and whole request head
  int max_per_client = 16;         // connections open at once per client (ClientKey)
  size_t max_waiting = 256;        // connections still sending their head, all clients
  size_t max_open = 1024;          // open in all (beyond: none accepted until some close)
  double read_timeout_s = 3;       // a worker's wait for more of the request, per read
  double write_timeout_s = 30;     // a worker's wait for room to write, per write
};

class ConnectionGate {
 public:
  static constexpr size_t kMaxHeadBytes = 16 * 1024;
  // Answers the one request whose head the stream starts with; the gate
  // closes the connection when it returns. Called on a worker thread.
  using Handler = std::function<void(httplib::Stream&)>;

  // Binds and listens. A port in use is an error naming the address ("...
  // in use"), as is an address that is not one of this host's. `log` (may
  // be null) must outlive the gate.
  static Result<std::unique_ptr<ConnectionGate>> Bind(const GateOptions& options, ClientLog* log);
  ~ConnectionGate();  // closes the listening socket; Run must have returned
  ConnectionGate(const ConnectionGate&) = delete;
  ConnectionGate& operator=(const ConnectionGate&) = delete;

  int port() const;
  int listen_fd() const;
  // Serves until Stop(): the loop on this thread, the workers on their own;
  // `tick` is called on this thread about once a second. Call once.
  void Run(const Handler& handler, const std::function<void()>& tick);
  // From any thread (not a signal handler): Run returns soon after.
  void Stop();

  struct Counts {
    uint64_t accepted = 0;
    uint64_t refused_over_cap = 0;    // closed at accept: the client had max_per_client open
    uint64_t dropped_waiting = 0;     // closed to make room: max_waiting were waiting
    uint64_t closed_at_deadline = 0;  // no complete head within head_deadline_s
    uint64_t tls_failed = 0;          // failed handshakes, plain HTTP to the TLS port
    uint64_t dispatched = 0;          // complete heads handed to the workers
  };
  Counts counts() const;

 private:
  struct Impl;
  explicit ConnectionGate(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imuqual::web

#endif  // IMUQUAL_WEB_CONNECTION_GATE_H_
