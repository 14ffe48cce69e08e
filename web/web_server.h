// `imuqual serve`: a read-only web server for the archive (web/pages.h),
// answered by cpp-httplib (Debian's libcpp-httplib) behind its own front door
// (web/connection_gate.h: accept loop, per-client connection cap, a deadline
// for the whole request head, TLS on OpenSSL). Every request opens the
// archive read-only (SQLite WAL: the station keeps writing meanwhile),
// answers GET and HEAD only, takes no request body (413), one request per
// connection.
//
// Transport: HTTPS with tls_cert_path and tls_key_path (web/tls.h: TLS 1.2
// or 1.3). Beyond a loopback address plain HTTP is refused at Start unless
// insecure_http says so (the token would cross the network in clear).
// Start ignores SIGPIPE in the process (a client that goes away mid-answer
// must not end it). A port in use is an error at Start, never a second
// listener.
//
// Access: on a loopback address without a token anyone on this host may
// read, and only requests whose Host names this host are answered (a web
// page whose name is rebound to 127.0.0.1 gets 421); with a token (required
// beyond loopback; CheckToken) a request must carry it as "Authorization:
// Bearer TOKEN", as "?token=TOKEN" (which also sets an HttpOnly,
// SameSite=Strict cookie, Secure under TLS, so that a browser's next pages
// need not carry it) or as that cookie, or it gets 401 and nothing else.
// Wrong tokens are throttled per client (TokenThrottle: after 5, a back-off
// doubling from 1 s to 5 min during which the client gets 429 and its token
// is not looked at) and logged per client at most once a minute with its
// address and counts (ClientLog), never the token.
//
// Pages load scripts only from this server (/assets/live.js,
// /assets/report.js) and nothing from anywhere else:
//   Content-Security-Policy: default-src 'none'; script-src 'self';
//   style-src 'unsafe-inline'; img-src data:; connect-src 'self';
//   form-action 'self'; base-uri 'none'; frame-ancestors 'none'
// (inline styles stay: the report's bars are sized by style attributes; no
// inline script runs). A lot report is served with its script as that file;
// `imuqual report` still writes it inline (a file needs no server).
//
// With a bus (live_feed.h): /live is the live station page, /live/events
// its server-sent events (at most 16 streams at once; 503 beyond),
// /api/live the latest status document and /api/live/curves?run=ID the
// latest curves of a run (JSON arrays).
//
// A finished lot's report (no run of it open) is kept while the archive
// leaves its runs and results unchanged (8 lots); with a bus, the report of
// a soak's lot is built as soon as the soak is over (every unit archived
// with its final result), so that the live page's report link opens at once.
#ifndef IMUQUAL_WEB_WEB_SERVER_H_
#define IMUQUAL_WEB_WEB_SERVER_H_

#include <functional>
#include <memory>
#include <string>

#include "common/bus_seal.h"

#include "common/status.h"
#include "web/connection_gate.h"

namespace imuqual::web {

struct ServeOptions {
  std::string db_path;             // the archive (must exist)
  std::string host = "127.0.0.1";  // address to listen on
  int port = 8080;                 // 0: any free port (see WebServer::port)
  std::string token;               // required unless host is a loopback address (CheckToken)
  // A station bus (LCM URL) for the live page (/live, /live/events,
  // /api/live); "" without one. With a bus the archive may not exist yet
  // (the station creates it): its pages say so until it does.
  std::string bus_url;
  BusSecurity bus_security;  // keys to listen with (role: monitor)
  // PEM certificate chain and its private key: HTTPS (both or neither).
  std::string tls_cert_path;
  std::string tls_key_path;
  // Plain HTTP on an address beyond loopback (the token in clear on the network).
  bool insecure_http = false;
  // Where the lines about clients go (wrong tokens, refused connections:
  // ClientLog); null: LogWarning.
  std::function<void(const std::string&)> client_log_sink;
};

// Whether `host` is a loopback address (127.0.0.0/8, ::1, localhost).
bool IsLoopback(const std::string& host);

// Parses "ADDR:PORT", "[IPV6]:PORT" or "PORT" (then 127.0.0.1) into *o.
Status ParseListen(const std::string& text, ServeOptions* o);

class WebServer {
 public:
  // Checks the options (errors name the option: kInvalidArgument), the
  // archive (a missing or foreign file is an error naming it) and the TLS
  // files, then binds (a port in use or a foreign address: kUnavailable).
  // Serving starts with Run().
  static Result<std::unique_ptr<WebServer>> Start(const ServeOptions& options);
  ~WebServer();
  int port() const;
  bool tls() const;
  // Serves until Stop() (from another thread, not a signal handler), then
  // logs the clients' counts not logged yet. Call once.
  void Run();
  void Stop();
  // The front door's counts (accepted, refused, closed at the deadline...).
  ConnectionGate::Counts GateCounts() const;
  // Finished lots' reports kept (see above); for tests.
  size_t ReportsKept() const;

 private:
  struct Impl;
  explicit WebServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imuqual::web

#endif  // IMUQUAL_WEB_WEB_SERVER_H_
