#include "web/web_server.h"

#include <arpa/inet.h>
#include <httplib.h>
#include <sodium.h>
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "common/clock.h"
#include "common/keys.h"
#include "common/log.h"
#include "common/text_util.h"
#include "report/report.h"
#include "store/archive.h"
#include "store/query.h"
#include "web/access.h"
#include "web/connection_gate.h"
#include "web/live_feed.h"
#include "web/live_page.h"
#include "web/pages.h"
#include "web/tls.h"

namespace imuqual::web {
namespace {

// A token's BLAKE2b digest: requests' tokens are compared with the right
// one's digest in constant time (sodium_memcmp), whatever their lengths.
using TokenDigest = std::array<unsigned char, crypto_generichash_BYTES>;
TokenDigest DigestOf(const std::string& token) {
  TokenDigest d{};
  crypto_generichash(d.data(), d.size(), reinterpret_cast<const unsigned char*>(token.data()),
                     token.size(), nullptr, 0);
  return d;
}
bool IsToken(const std::string& given, const TokenDigest& token) {
  const TokenDigest d = DigestOf(given);
  return sodium_memcmp(d.data(), token.data(), d.size()) == 0;
}

constexpr int kMaxStreams = 16;  // live event streams at once (each holds a worker)
constexpr int kKeepAliveS = 15;  // a comment line this often on a quiet stream
constexpr char kTokenCookie[] = "imuqual_token";

// A Host header naming this host: 127.x.y.z, localhost or [::1], with or
// without a port.
bool LocalHostHeader(const std::string& host) {
  std::string name = host;
  if (!name.empty() && name.front() == '[') {
    name = name.substr(1, name.find(']') == std::string::npos ? 0 : name.find(']') - 1);
  } else if (const size_t colon = name.rfind(':'); colon != std::string::npos) {
    name = name.substr(0, colon);
  }
  return IsLoopback(name);
}

// The value of cookie `name` in a Cookie header, "" if absent.
std::string CookieValue(const std::string& header, const std::string& name) {
  size_t at = 0;
  while (at < header.size()) {
    size_t end = header.find(';', at);
    if (end == std::string::npos) end = header.size();
    std::string pair = header.substr(at, end - at);
    const size_t start = pair.find_first_not_of(' ');
    pair = start == std::string::npos ? "" : pair.substr(start);
    if (pair.rfind(name + "=", 0) == 0) return pair.substr(name.size() + 1);
    at = end + 1;
  }
  return "";
}

constexpr char kSecurityPolicy[] =
    "default-src 'none'; script-src 'self'; style-src 'unsafe-inline'; img-src data:; "
    "connect-src 'self'; form-action 'self'; base-uri 'none'; frame-ancestors 'none'";
constexpr char kReportScriptPath[] = "/assets/report.js";
constexpr char kLiveScriptPath[] = "/assets/live.js";

// A page from Route with the lot report's inline script (the only inline
// script Route makes) replaced by the same script as a file of this server,
// which the policy above lets run.
Page WithScriptAsFile(Page page) {
  if (page.content_type.rfind("text/html", 0) != 0) return page;
  const std::string inline_script =
      "<script>" + std::string(report::LotReportScript()) + "</script>";
  const size_t at = page.body.rfind(inline_script);
  if (at != std::string::npos) {
    page.body.replace(at, inline_script.size(),
                      std::string("<script src=\"") + kReportScriptPath + "\"></script>");
  }
  return page;
}

// The lot a request for `prefix`/LOT or `prefix`?name=LOT names ("" for
// another path).
std::string LotOfPath(const httplib::Request& req, const std::string& prefix) {
  if (req.path == prefix) return req.get_param_value("name");
  if (req.path.size() > prefix.size() + 1 && req.path.compare(0, prefix.size(), prefix) == 0 &&
      req.path[prefix.size()] == '/') {
    return req.path.substr(prefix.size() + 1);
  }
  return "";
}

// A lot report's deferred sections (report::RenderLotSection).
constexpr const char* kSections[] = {"lot-model", "lot-plots", "unit-plots"};
bool IsSection(const std::string& part) {
  return std::find(std::begin(kSections), std::end(kSections), part) != std::end(kSections);
}

// cpp-httplib's server, answering the requests that the gate hands it.
class GatedServer : public httplib::Server {
 public:
  // Parses the request at the head of `stream`, routes it, writes the
  // response with "Connection: close".
  void Answer(httplib::Stream& stream) {
    bool closed = true;
    process_request(stream, /*close_connection=*/true, closed, nullptr);
  }
  // cpp-httplib streams a response (an event stream) only while it believes
  // that it listens (a valid svr_sock_): the gate's socket while serving,
  // none once stopping, which ends every stream.
  void SetListening(int fd) { svr_sock_ = fd; }
};

}  // namespace

bool IsLoopback(const std::string& host) {
  if (host == "localhost" || host == "::1") return true;
  in_addr a{};
  return inet_pton(AF_INET, host.c_str(), &a) == 1 && (ntohl(a.s_addr) >> 24) == 127;
}

Status ParseListen(const std::string& text, ServeOptions* o) {
  std::string host = o->host, port = text;
  if (!text.empty() && text.front() == '[') {
    const size_t close = text.find(']');
    if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':')
      return Status::InvalidArgument("--listen: '" + text + "' is not [IPV6]:PORT");
    host = text.substr(1, close - 1);
    port = text.substr(close + 2);
  } else if (const size_t colon = text.rfind(':'); colon != std::string::npos) {
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
  }
  char* end = nullptr;
  const long p = std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || p < 0 || p > 65535)
    return Status::InvalidArgument("--listen: '" + text + "': the port must be 0-65535");
  if (host.empty()) return Status::InvalidArgument("--listen: '" + text + "' has no address");
  o->host = host;
  o->port = static_cast<int>(p);
  return Status::Ok();
}

// Lot reports of lots whose runs are all finished, kept while the archive
// says they are unchanged (store::QueryLotFingerprint): a 100-unit lot's report
// fits a noise model per axis, too slow to redo for every view.
class ReportCache {
 public:
  std::optional<Page> Find(const std::string& lot, const std::string& fingerprint) {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = entries_.find(lot);
    if (it == entries_.end() || it->second.fingerprint != fingerprint) return std::nullopt;
    it->second.used = ++clock_;
    return it->second.page;
  }
  size_t size() {
    std::lock_guard<std::mutex> lock(mu_);
    return entries_.size();
  }
  void Put(const std::string& lot, const std::string& fingerprint, const Page& page) {
    std::lock_guard<std::mutex> lock(mu_);
    if (entries_.size() >= kMaxLots && entries_.count(lot) == 0) {
      auto oldest = std::min_element(
          entries_.begin(), entries_.end(),
          [](const auto& a, const auto& b) { return a.second.used < b.second.used; });
      entries_.erase(oldest);
    }
    entries_[lot] = {fingerprint, page, ++clock_};
  }

 private:
  static constexpr size_t kMaxLots = 8;
  struct Entry {
    std::string fingerprint;
    Page page;
    uint64_t used = 0;
  };
  std::mutex mu_;
  std::map<std::string, Entry> entries_;
  uint64_t clock_ = 0;
};

struct WebServer::Impl {
  ServeOptions options;
  ReportCache reports;
  // The lot pages' deferred sections, by part (every part made before the
  // server's threads start: looked up, never inserted, while serving).
  std::map<std::string, ReportCache> sections;
  std::unique_ptr<LiveFeed> feed;  // with a bus
  std::atomic<bool> stopping{false};
  std::atomic<int> streams{0};
  std::unique_ptr<TlsContext> tls;  // with HTTPS
  std::unique_ptr<ClientLog> client_log;
  TokenThrottle throttle;
  TokenDigest token_digest{};  // of options.token
  GatedServer server;
  std::unique_ptr<ConnectionGate> gate;  // after tls and client_log: it uses both
  // With a bus: builds the report of a soak's lot once the soak is over.
  std::thread warmer;
  std::mutex warm_mu;
  std::condition_variable warm_cv;

  void WarmReports() {
    std::string kept;  // the lot whose report was last kept
    while (!stopping) {
      {
        std::unique_lock<std::mutex> lock(warm_mu);
        warm_cv.wait_for(lock, std::chrono::seconds(1), [&] { return stopping.load(); });
      }
      const std::string lot = feed->DoneLot();
      struct stat info {};
      if (stopping || lot.empty() || lot == kept || ::stat(options.db_path.c_str(), &info) != 0)
        continue;
      auto archive = store::Archive::Open(options.db_path, store::Archive::Mode::kRead);
      if (!archive.ok()) continue;
      // Not kept while a run of it is still open (the store finalizes last).
      auto fingerprint = store::QueryLotFingerprint(**archive, lot);
      if (!fingerprint.ok() || fingerprint->empty()) continue;
      bool warmed = true;
      std::vector<std::pair<ReportCache*, std::string>> parts = {{&reports, ""}};
      for (const char* part : kSections) parts.emplace_back(&sections.at(part), part);
      for (const auto& [cache, part] : parts) {
        if (cache->Find(lot, *fingerprint)) continue;
        const Page page = WithScriptAsFile(
            part.empty() ? Route(**archive, options.db_path, "/lot/" + lot, {})
                         : Route(**archive, options.db_path, "/lot-section",
                                 {{"name", lot}, {"part", part}}));
        if (page.status != 200) {
          warmed = false;
          break;
        }
        cache->Put(lot, *fingerprint, page);
      }
      if (warmed) kept = lot;
    }
  }
};

WebServer::WebServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
WebServer::~WebServer() { Stop(); }
int WebServer::port() const { return impl_->gate->port(); }
bool WebServer::tls() const { return impl_->tls != nullptr; }
size_t WebServer::ReportsKept() const { return impl_->reports.size(); }
ConnectionGate::Counts WebServer::GateCounts() const { return impl_->gate->counts(); }

void WebServer::Run() {
  Impl* state = impl_.get();
  if (!state->stopping) state->server.SetListening(state->gate->listen_fd());
  state->gate->Run([state](httplib::Stream& stream) { state->server.Answer(stream); },
                   [state] { state->client_log->Flush(MonotonicSeconds(), /*all=*/false); });
  state->client_log->Flush(MonotonicSeconds(), /*all=*/true);
}

void WebServer::Stop() {
  impl_->stopping = true;  // event streams end within a second
  impl_->server.SetListening(INVALID_SOCKET);
  impl_->warm_cv.notify_all();
  impl_->gate->Stop();
  if (impl_->warmer.joinable() && impl_->warmer.get_id() != std::this_thread::get_id())
    impl_->warmer.join();
}

Result<std::unique_ptr<WebServer>> WebServer::Start(const ServeOptions& o) {
  const std::string where = o.host.find(':') == std::string::npos ? o.host : "[" + o.host + "]";
  if (!IsLoopback(o.host) && o.token.empty()) {
    return Status::InvalidArgument("serve: listening on " + where +
                                   " (not a loopback address) needs a token (--token-file FILE, "
                                   "--new-token, or --token TOKEN): anyone who can reach it "
                                   "could read the archive");
  }
  if (!o.token.empty()) IMUQUAL_RETURN_IF_ERROR(CheckToken(o.token));
  IMUQUAL_RETURN_IF_ERROR(InitCrypto());
  const bool tls = !o.tls_cert_path.empty() || !o.tls_key_path.empty();
  if (tls && (o.tls_cert_path.empty() || o.tls_key_path.empty()))
    return Status::InvalidArgument("serve: --tls-cert FILE and --tls-key FILE go together");
  if (tls && o.insecure_http) {
    return Status::InvalidArgument(
        "serve: --insecure-http and --tls-cert/--tls-key contradict each other: give one");
  }
  if (!IsLoopback(o.host) && !tls && !o.insecure_http) {
    return Status::InvalidArgument("serve: listening on " + where +
                                   " (not a loopback address) needs --tls-cert FILE --tls-key "
                                   "FILE, or --insecure-http to send the token in clear");
  }
  struct stat info {};
  const bool exists = ::stat(o.db_path.c_str(), &info) == 0;
  if (exists || o.bus_url.empty()) {
    auto archive = store::Archive::Open(o.db_path, store::Archive::Mode::kRead);
    if (!archive.ok()) return archive.status();
  }
  auto impl = std::make_unique<Impl>();
  for (const char* part : kSections) impl->sections.try_emplace(part);  // before any thread
  impl->options = o;
  impl->token_digest = DigestOf(o.token);
  if (!o.bus_url.empty()) {
    auto feed = LiveFeed::Open(o.bus_url, o.db_path, o.bus_security);
    if (!feed.ok()) return feed.status();
    impl->feed = std::move(*feed);
  }
  if (tls) {
    auto loaded = TlsContext::Load(o.tls_cert_path, o.tls_key_path);
    if (!loaded.ok()) return loaded.status();
    impl->tls = std::move(*loaded);
  }
  impl->client_log = std::make_unique<ClientLog>(
      o.client_log_sink ? o.client_log_sink : [](const std::string& line) { LogWarning(line); });
  GateOptions gate;
  gate.host = o.host;
  gate.port = o.port;
  gate.tls = impl->tls ? impl->tls->get() : nullptr;
  auto bound = ConnectionGate::Bind(gate, impl->client_log.get());
  if (!bound.ok()) return bound.status();
  impl->gate = std::move(*bound);
  std::signal(SIGPIPE, SIG_IGN);  // a client gone mid-answer fails the write, not the process
  Impl* state = impl.get();
  GatedServer& s = impl->server;
  s.set_payload_max_length(1024);  // nothing here takes a body
  const ServeOptions opts = o;
  // Before any route: methods, the token, then the page.
  s.set_pre_routing_handler([opts, state](const httplib::Request& req, httplib::Response& res) {
    res.set_header("Content-Security-Policy", kSecurityPolicy);
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_header("Referrer-Policy", "no-referrer");
    res.set_header("Cache-Control", "no-store");
    if (req.method != "GET" && req.method != "HEAD") {
      res.status = 405;
      res.set_header("Allow", "GET, HEAD");
      res.set_content("read-only: GET and HEAD only\n", "text/plain; charset=utf-8");
      return httplib::Server::HandlerResponse::Handled;
    }
    // A GET's body is never read (cpp-httplib reads bodies of POST, PUT,
    // PATCH and DELETE only): a request that announces one is refused.
    const std::string length = req.get_header_value("Content-Length");
    if ((!length.empty() && length != "0") || req.has_header("Transfer-Encoding")) {
      res.status = 413;
      res.set_content("no request body is taken\n", "text/plain; charset=utf-8");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (opts.token.empty()) {
      // Loopback without a token: only a Host naming this host, so that a
      // web page whose name is rebound to 127.0.0.1 cannot read the archive.
      if (!LocalHostHeader(req.get_header_value("Host"))) {
        res.status = 421;
        res.set_content("this server answers to 127.0.0.1, localhost or [::1] only\n",
                        "text/plain; charset=utf-8");
        return httplib::Server::HandlerResponse::Handled;
      }
    } else {
      // A client backing off is refused before its token is looked at, so
      // that a guess made meanwhile tests nothing.
      const std::string client = ClientKey(req.remote_addr);
      const double now_s = MonotonicSeconds();
      if (const double wait_s = state->throttle.WaitS(client, now_s); wait_s > 0) {
        state->client_log->Note(client, ClientLog::Event::kRefusedBackingOff, now_s);
        const std::string seconds = std::to_string(static_cast<long>(std::ceil(wait_s)));
        res.status = 429;
        res.set_header("Retry-After", seconds);
        res.set_content("too many wrong tokens from this address: try again in " + seconds + " s\n",
                        "text/plain; charset=utf-8");
        return httplib::Server::HandlerResponse::Handled;
      }
      // The token: a Bearer header, ?token= (which also sets a cookie, so
      // that a browser's next pages need not carry it), or that cookie.
      std::string given;
      bool from_query = false;
      const std::string auth = req.get_header_value("Authorization");
      if (auth.rfind("Bearer ", 0) == 0) {
        given = auth.substr(7);
      } else if (req.has_param("token")) {
        given = req.get_param_value("token");
        from_query = true;
      } else {
        given = CookieValue(req.get_header_value("Cookie"), kTokenCookie);
      }
      if (!IsToken(given, state->token_digest)) {
        if (!given.empty()) {  // a request without any token guesses nothing
          state->throttle.Failed(client, now_s);
          state->client_log->Note(client, ClientLog::Event::kWrongToken, now_s);
        }
        res.status = 401;
        res.set_header("WWW-Authenticate", "Bearer");
        res.set_content("a token is needed: Authorization: Bearer TOKEN, or ?token=TOKEN\n",
                        "text/plain; charset=utf-8");
        return httplib::Server::HandlerResponse::Handled;
      }
      if (state->throttle.Failures(client) > 0) state->throttle.Succeeded(client);
      if (from_query) {
        res.set_header("Set-Cookie", std::string(kTokenCookie) + "=" + given +
                                         "; Path=/; HttpOnly; SameSite=Strict" +
                                         (state->tls ? "; Secure" : ""));
      }
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // The pages' scripts, the only ones that run (script-src 'self').
  s.Get(kLiveScriptPath, [](const httplib::Request&, httplib::Response& res) {
    res.set_content(LivePageScript(), "text/javascript; charset=utf-8");
  });
  s.Get(kReportScriptPath, [](const httplib::Request&, httplib::Response& res) {
    res.set_content(std::string(report::LotReportScript()), "text/javascript; charset=utf-8");
  });
  // The live station (with a bus).
  s.Get("/live", [opts](const httplib::Request&, httplib::Response& res) {
    res.set_content(LivePageHtml(opts.bus_url), "text/html; charset=utf-8");
  });
  s.Get("/api/live", [state](const httplib::Request&, httplib::Response& res) {
    if (!state->feed) {
      res.status = 404;
      res.set_content("{\"error\": \"no bus: start serve with --bus URL\"}\n", "application/json");
      return;
    }
    res.set_content(state->feed->StatusJson() + "\n", "application/json; charset=utf-8");
  });
  s.Get("/api/live/curves", [state](const httplib::Request& req, httplib::Response& res) {
    if (!state->feed) {
      res.status = 404;
      res.set_content("{\"error\": \"no bus: start serve with --bus URL\"}\n", "application/json");
      return;
    }
    res.set_content(state->feed->CurvesJson(req.get_param_value("run")),
                    "application/json; charset=utf-8");
  });
  s.Get("/live/events", [state](const httplib::Request&, httplib::Response& res) {
    if (!state->feed) {
      res.status = 404;
      res.set_content("no bus: start serve with --bus URL\n", "text/plain; charset=utf-8");
      return;
    }
    if (state->streams.fetch_add(1) >= kMaxStreams) {
      state->streams.fetch_sub(1);
      res.status = 503;
      res.set_header("Retry-After", "10");
      res.set_content("too many live pages open\n", "text/plain; charset=utf-8");
      return;
    }
    auto cursor = std::make_shared<LiveFeed::Cursor>();
    auto quiet = std::make_shared<int>(0);
    res.set_chunked_content_provider(
        "text/event-stream",
        [state, cursor, quiet](size_t, httplib::DataSink& sink) {
          if (state->stopping || state->feed->stopping()) return false;
          std::string events = state->feed->NextEvents(cursor.get(), std::chrono::seconds(1));
          if (events.empty()) {
            if (++*quiet < kKeepAliveS) return true;
            events = ": still here\n\n";  // a closed page is found by the failed write
          }
          *quiet = 0;
          return sink.write(events.data(), events.size());
        },
        [state](bool) { state->streams.fetch_sub(1); });
  });
  s.Get(".*", [opts, state](const httplib::Request& req, httplib::Response& res) {
    std::map<std::string, std::string> query;
    for (const auto& [k, v] : req.params) query.emplace(k, v);
    struct stat info {};
    if (!opts.bus_url.empty() && ::stat(opts.db_path.c_str(), &info) != 0) {
      res.status = 503;
      res.set_content(
          PageHtml("no archive yet", "<h1>No archive yet</h1>\n<p>" + HtmlEscape(opts.db_path) +
                                         " does not exist yet: the station creates it "
                                         "when its soak starts. <a href=\"/live\">The "
                                         "live station</a>.</p>\n"),
          "text/html; charset=utf-8");
      return;
    }
    auto archive = store::Archive::Open(opts.db_path, store::Archive::Mode::kRead);
    Page page;
    if (!archive.ok()) {
      page = {500, "text/plain; charset=utf-8", archive.status().message() + "\n"};
    } else if (const std::string lot = LotOfPath(req, "/lot"),
               section_lot = req.path == "/lot-section" ? req.get_param_value("name") : "";
               !lot.empty() || (!section_lot.empty() && IsSection(req.get_param_value("part")))) {
      // A finished lot's report, or one of its sections, kept while the
      // archive leaves the lot unchanged.
      ReportCache& cache =
          lot.empty() ? state->sections.at(req.get_param_value("part")) : state->reports;
      const std::string& name = lot.empty() ? section_lot : lot;
      auto fingerprint = store::QueryLotFingerprint(**archive, name);
      std::optional<Page> kept;
      if (fingerprint.ok() && !fingerprint->empty()) kept = cache.Find(name, *fingerprint);
      if (kept) {
        page = std::move(*kept);
      } else {
        page = WithScriptAsFile(Route(**archive, opts.db_path, req.path, query));
        if (page.status == 200 && fingerprint.ok() && !fingerprint->empty())
          cache.Put(name, *fingerprint, page);
      }
    } else {
      page = WithScriptAsFile(Route(**archive, opts.db_path, req.path, query));
    }
    res.status = page.status;
    res.set_content(page.body, page.content_type.c_str());
  });
  if (impl->feed) impl->warmer = std::thread([state] { state->WarmReports(); });
  return std::unique_ptr<WebServer>(new WebServer(std::move(impl)));
}

}  // namespace imuqual::web
