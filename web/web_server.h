// `imuqual serve`: a read-only HTTP server for the archive (web/pages.h),
// on cpp-httplib (Debian's libcpp-httplib). Every request opens the archive
// read-only (SQLite WAL: the station keeps writing meanwhile), answers GET
// and HEAD only, takes no request body, and sends pages that load nothing
// from anywhere else (Content-Security-Policy default-src 'none').
//
// Access: on a loopback address anyone on this host may read, and only
// requests whose Host names this host are answered (a web page whose name is
// rebound to 127.0.0.1 gets 421); on any other address a token is required
// (Start refuses without one; at least 12 of A-Z a-z 0-9 -._~+/=), given as
// "Authorization: Bearer TOKEN", as "?token=TOKEN" (which also sets an
// HttpOnly, SameSite=Strict cookie so that a browser's next pages need not
// carry it) or as that cookie; a request without it gets 401 and nothing
// else. One request per connection; a request that announces a body is
// refused (413); 32 workers, each held by a slow client for at most 3 s per
// read. Exposed beyond a trusted network, put it behind a proxy.
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

#include <memory>
#include <string>

#include "common/bus_seal.h"

#include "common/status.h"

namespace imuqual::web {

struct ServeOptions {
  std::string db_path;             // the archive (must exist)
  std::string host = "127.0.0.1";  // address to listen on
  int port = 8080;                 // 0: any free port (see WebServer::port)
  std::string token;               // required unless host is a loopback address
  // A station bus (LCM URL) for the live page (/live, /live/events,
  // /api/live); "" without one. With a bus the archive may not exist yet
  // (the station creates it): its pages say so until it does.
  std::string bus_url;
  BusSecurity bus_security;  // keys to listen with (role: monitor)
};

// Whether `host` is a loopback address (127.0.0.0/8, ::1, localhost).
bool IsLoopback(const std::string& host);

// Parses "ADDR:PORT", "[IPV6]:PORT" or "PORT" (then 127.0.0.1) into *o.
Status ParseListen(const std::string& text, ServeOptions* o);

class WebServer {
 public:
  // Binds (the archive is checked first: a missing or foreign file is an
  // error naming it). Serving starts with Run().
  static Result<std::unique_ptr<WebServer>> Start(const ServeOptions& options);
  ~WebServer();
  int port() const;
  // Serves until Stop() (from another thread or a signal handler's thread).
  void Run();
  void Stop();
  // Finished lots' reports kept (see below); for tests.
  size_t ReportsKept() const;

 private:
  struct Impl;
  explicit WebServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace imuqual::web

#endif  // IMUQUAL_WEB_WEB_SERVER_H_
