// imuqual serve, in-process on a loopback port: the pages agree with the
// archive and with the report's own code, hostile strings are inert, the
// server only reads, and a token guards it when asked.
#include <gtest/gtest.h>
#include <httplib.h>

#include <nlohmann/json.hpp>
#include <map>
#include <string>
#include <thread>

#include "common/channels.h"
#include "common/lcm_bus.h"
#include "common/strings.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/allan_curve_t.hpp"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/status_t.hpp"
#include "imuqual/unit_result_t.hpp"
#include "report/report.h"
#include "store/archive.h"
#include "store/chunk_codec.h"
#include "store/outcome.h"
#include "store/run_record.h"
#include "tests/test_util.h"
#include "web/live_feed.h"
#include "web/pages.h"
#include "web/web_server.h"

namespace imuqual::web {
namespace {

// A server started from `o` and served on a thread until the test ends
// (however it ends: a failed ASSERT returns early, and a joinable thread
// would terminate the binary); `client` answers once it serves.
class TestServer {
 public:
  explicit TestServer(const ServeOptions& o) {
    auto s = WebServer::Start(o);
    EXPECT_TRUE(s.ok()) << s.status().ToString();
    if (!s.ok()) return;
    server_ = std::move(*s);
    thread_ = std::thread([this] { server_->Run(); });
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    for (int i = 0; i < 200 && !client_->Get("/live"); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ~TestServer() {
    if (server_) server_->Stop();
    if (thread_.joinable()) thread_.join();
  }
  bool ok() const { return client_ != nullptr; }
  httplib::Client& client() { return *client_; }
  WebServer& server() { return *server_; }

 private:
  std::unique_ptr<WebServer> server_;
  std::thread thread_;
  std::unique_ptr<httplib::Client> client_;
};

// A lot and a unit whose names try to break out of HTML, attributes and JSON.
const std::string kLot = "L<script>alert(1)</script>\"'&";
const std::string kSerial = "S\"><img src=x onerror=alert(2)>";
const std::string kRun = "R-1";

// A run of one gyro axis at 100 Hz, started at `start_utime`.
store::RunInfo OneAxisRun(const std::string& run_id, const std::string& serial,
                          const std::string& lot, int64_t start_utime) {
  store::RunInfo r;
  r.run_id = run_id;
  r.serial = serial;
  r.lot = lot;
  r.station = "bench";
  r.start_utime = start_utime;
  r.nominal_rate_hz = 100;
  r.axes = {{"gx", pb::GYRO}};
  r.state = "running";
  return r;
}

// Ends run `r` (archived as `key`) complete 1 s after its start, with result
// `res` judged 2 s after it, and finalizes it.
void Finish(store::Archive& a, int64_t key, store::RunInfo r, store::ResultRecord res) {
  r.state = "complete";
  r.end_utime = r.start_utime + 1'000'000;
  ASSERT_TRUE(a.UpsertRun(r).ok());
  res.result_utime = r.start_utime + 2'000'000;
  res.record = store::BuildRunRecord(r, res, 0).SerializeAsString();
  ASSERT_TRUE(a.PutResult(key, res).ok());
  ASSERT_TRUE(a.MarkFinalized(key, res.result_utime).ok());
}

std::string MakeArchive(const testing::TempDir& dir) {
  const std::string db = dir.path("web.db");
  auto a = store::Archive::Open(db, store::Archive::Mode::kWrite);
  EXPECT_TRUE(a.ok()) << a.status().ToString();
  store::RunInfo r = OneAxisRun(kRun, kSerial, kLot, 1'800'000'000'000'000);
  r.station = "bench<1>";
  r.slot = "A1";
  r.operator_name = "Ana M\u00fcller \u2014 \u6d4b\u8bd5 </td><script>x</script>";
  auto key = (*a)->UpsertRun(r);
  EXPECT_TRUE(key.ok());
  store::ResultRecord res;
  res.verdict = "FAIL";
  res.reasons = {"gx: bias_instability 9.25 deg/h above high limit 5 <b>"};
  pb::Measurement m;
  m.set_axis("gx");
  m.set_name("bias_instability");
  m.set_value(9.2500000000000018);
  m.set_uncertainty(0.125);
  m.set_unit("deg/h");
  m.set_high(5);
  m.set_outcome(pb::FAIL);
  res.measurements.push_back(m);
  Finish(**a, *key, r, res);
  return db;
}

std::string Encode(const std::string& s) {
  static const char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : s) {
    if (std::isalnum(c)) {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

class WebTest : public ::testing::Test {
 protected:
  void SetUp() override { db_ = MakeArchive(dir_); }
  void Serve(const std::string& token = "") {
    ServeOptions o;
    o.db_path = db_;
    o.port = 0;
    o.token = token;
    server_ = std::make_unique<TestServer>(o);
    ASSERT_TRUE(server_->ok());
    client_ = &server_->client();
  }
  testing::TempDir dir_{"web_test"};
  std::string db_;
  std::unique_ptr<TestServer> server_;
  httplib::Client* client_ = nullptr;
};

// Every page from the archive is there, agrees with it, and renders the
// hostile names as text.
// Connections to `url` that speak as acquire, analyze and the store.
struct RoleBuses {
  explicit RoleBuses(const std::string& url) {
    for (BusRole role : {BusRole::kAcquire, BusRole::kAnalyze, BusRole::kStore}) {
      BusSecurity as;
      as.role = role;
      auto bus = LcmBus::Open(url, as);
      EXPECT_TRUE(bus.ok()) << bus.status().ToString();
      if (bus.ok()) buses[role] = std::move(*bus);
    }
  }
  bool ok() const { return buses.size() == 3; }
  LcmBus& acquire() { return *buses.at(BusRole::kAcquire); }
  LcmBus& analyze() { return *buses.at(BusRole::kAnalyze); }
  LcmBus& store() { return *buses.at(BusRole::kStore); }
  std::map<BusRole, std::unique_ptr<LcmBus>> buses;
};

TEST_F(WebTest, PagesShowTheArchiveWithEveryNameEscaped) {
  Serve();
  auto home = client_->Get("/");
  ASSERT_TRUE(home);
  EXPECT_EQ(home->status, 200);
  EXPECT_NE(home->get_header_value("Content-Security-Policy").find("default-src 'none'"),
            std::string::npos);
  EXPECT_NE(home->body.find("L&lt;script&gt;alert(1)&lt;/script&gt;&quot;&#39;&amp;"),
            std::string::npos)
      << home->body;
  EXPECT_NE(home->body.find("href=\"/lot/" + Encode(kLot) + "\""), std::string::npos) << home->body;
  // The lot page is the report, byte for byte as the report's code builds it.
  auto lot = client_->Get("/lot/" + Encode(kLot));
  ASSERT_TRUE(lot);
  EXPECT_EQ(lot->status, 200);
  auto archive = store::Archive::Open(db_, store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok());
  auto report = report::BuildLotReportHtml(**archive, kLot, db_);
  ASSERT_TRUE(report.ok());
  auto strip_time = [](std::string s) {  // the report says when it was generated
    const size_t at = s.find(" on 20");
    return at == std::string::npos ? s : s.substr(0, at);
  };
  EXPECT_EQ(strip_time(lot->body), strip_time(*report));
  // The run page: the value exactly (data-v), its limit, outcome and reasons.
  auto run = client_->Get("/run/" + kRun);
  ASSERT_TRUE(run);
  EXPECT_EQ(run->status, 200);
  EXPECT_NE(run->body.find("data-v=\"" + ShortestReal(9.2500000000000018) + "\""),
            std::string::npos)
      << run->body;
  EXPECT_NE(run->body.find("data-v=\"0.125\""), std::string::npos);
  EXPECT_NE(run->body.find("above high limit 5 &lt;b&gt;"), std::string::npos);
  // Unicode passes through as UTF-8; markup is escaped.
  EXPECT_NE(run->body.find(
                "Ana M\u00fcller \u2014 \u6d4b\u8bd5 &lt;/td&gt;&lt;script&gt;x&lt;/script&gt;"),
            std::string::npos);
  for (const auto* body : {&home->body, &lot->body, &run->body}) {
    EXPECT_EQ(body->find("<script>alert"), std::string::npos);
    EXPECT_EQ(body->find("<img src=x"), std::string::npos);
  }
  // The unit's history, by path and by the search form.
  auto unit = client_->Get("/unit?serial=" + Encode(kSerial));
  ASSERT_TRUE(unit);
  EXPECT_EQ(unit->status, 200);
  EXPECT_NE(unit->body.find("href=\"/run/R-1\""), std::string::npos) << unit->body;
  // JSON for programs: the same columns as the imuqual command's.
  auto api = client_->Get("/api/run/" + kRun);
  ASSERT_TRUE(api);
  EXPECT_EQ(api->status, 200);
  EXPECT_EQ(api->get_header_value("Content-Type"), "application/json; charset=utf-8");
  EXPECT_NE(api->body.find("\"value\": " + ShortestReal(9.2500000000000018)), std::string::npos)
      << api->body;
  auto runs = client_->Get("/api/runs?lot=" + Encode(kLot));
  ASSERT_TRUE(runs);
  EXPECT_NE(runs->body.find("\"serial\": \"S\\\"><img src=x onerror=alert(2)>\""),
            std::string::npos)
      << runs->body;
  // Two lots compared (here the lot with itself: nothing differs), as
  // `imuqual compare` computes it.
  auto compare = client_->Get("/compare?a=" + Encode(kLot) + "&b=" + Encode(kLot));
  ASSERT_TRUE(compare);
  EXPECT_EQ(compare->status, 200);
  EXPECT_NE(compare->body.find("bias_instability"), std::string::npos) << compare->body;
  auto compare_json = client_->Get("/api/compare?a=" + Encode(kLot) + "&b=" + Encode(kLot));
  ASSERT_TRUE(compare_json);
  EXPECT_NE(compare_json->body.find("\"mean_change\": 0"), std::string::npos) << compare_json->body;
  auto compare_none = client_->Get("/compare?a=" + Encode(kLot) + "&b=NOPE");
  ASSERT_TRUE(compare_none);
  EXPECT_EQ(compare_none->status, 404);
  // What the archive does not hold: 404.
  for (const char* path : {"/run/NOPE", "/lot/NOPE", "/unit/NOPE", "/nothing", "/api/run/NOPE"}) {
    auto r = client_->Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 404) << path;
  }
}

// Read-only and closed: other methods, bodies and paths out of the tree are
// refused; no file of the host is ever served.
TEST_F(WebTest, OnlyReadsAndServesNoFile) {
  Serve();
  auto post = client_->Post("/", "x=1", "application/x-www-form-urlencoded");
  ASSERT_TRUE(post);
  EXPECT_EQ(post->status, 405);
  auto del = client_->Delete("/run/" + kRun);
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 405);
  for (const char* path : {"/../../../../etc/passwd", "/lot/..%2F..%2F..%2Fetc%2Fpasswd",
                           "/run/%2e%2e/%2e%2e/etc/passwd", "/web.db"}) {
    auto r = client_->Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 404) << path;
    EXPECT_EQ(r->body.find("root:"), std::string::npos) << path;
    EXPECT_EQ(r->body.find("SQLite format"), std::string::npos) << path;
  }
  // A GET that announces a body is refused (its body would otherwise be
  // read as the next request).
  auto with_body = client_->Get("/", {{"Content-Length", "5"}});
  ASSERT_TRUE(with_body);
  EXPECT_EQ(with_body->status, 413);
  // A page whose host name was rebound to 127.0.0.1 is not answered.
  auto rebound = client_->Get("/api/lots", {{"Host", "evil.example:8080"}});
  ASSERT_TRUE(rebound);
  EXPECT_EQ(rebound->status, 421);
  EXPECT_EQ(rebound->body.find(kLot), std::string::npos);
  auto local = client_->Get("/api/lots", {{"Host", "localhost:8080"}});
  ASSERT_TRUE(local);
  EXPECT_EQ(local->status, 200);
  // A request too long to be one of ours.
  auto huge = client_->Get("/run/" + std::string(20000, 'a'));
  ASSERT_TRUE(huge);
  EXPECT_GE(huge->status, 400);
  // The archive stays as it was.
  auto archive = store::Archive::Open(db_, store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok());
}

// With a token: nothing without it, everything with it (header or query).
TEST_F(WebTest, ATokenGuardsEveryPage) {
  Serve("s3cret-token-42");
  auto none = client_->Get("/");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 401);
  EXPECT_EQ(none->body.find("Lots"), std::string::npos);
  auto wrong = client_->Get("/?token=s3cret-token-4Z");
  ASSERT_TRUE(wrong);
  EXPECT_EQ(wrong->status, 401);
  auto query = client_->Get("/?token=s3cret-token-42");
  ASSERT_TRUE(query);
  EXPECT_EQ(query->status, 200);
  // ... which leaves a cookie for the browser's next pages.
  const std::string cookie = query->get_header_value("Set-Cookie");
  EXPECT_NE(cookie.find("imuqual_token=s3cret-token-42"), std::string::npos) << cookie;
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos) << cookie;
  auto with_cookie =
      client_->Get("/run/" + kRun, {{"Cookie", "a=1; imuqual_token=s3cret-token-42"}});
  ASSERT_TRUE(with_cookie);
  EXPECT_EQ(with_cookie->status, 200);
  auto bad_cookie = client_->Get("/run/" + kRun, {{"Cookie", "imuqual_token=nope"}});
  ASSERT_TRUE(bad_cookie);
  EXPECT_EQ(bad_cookie->status, 401);
  auto header = client_->Get("/api/lots", {{"Authorization", "Bearer s3cret-token-42"}});
  ASSERT_TRUE(header);
  EXPECT_EQ(header->status, 200);
}

// A damaged chunk costs the unit's raw-sample plot, not the lot's report.
TEST(WebPagesTest, ADamagedChunkCostsOnlyItsPlot) {
  testing::TempDir dir("web_damaged");
  const std::string db = MakeArchive(dir);
  {
    auto a = store::Archive::Open(db, store::Archive::Mode::kWrite);
    ASSERT_TRUE(a.ok());
    auto key = (*a)->FindRunKey(kRun);
    ASSERT_TRUE(key.ok() && key->has_value());
    store::ChunkRecord c;
    c.seq = 0;
    c.first_sample = 0;
    c.num_samples = 10;
    c.codec = store::kCodecRawFloat32;
    c.data = {1, 2, 3};  // not 10 float32 values
    ASSERT_TRUE((*a)->InsertChunk(**key, c, nullptr).ok());
  }
  auto archive = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok());
  const Page lot = Route(**archive, db, "/lot/" + kLot, {});
  EXPECT_EQ(lot.status, 200);
  EXPECT_NE(lot.body.find("raw samples not plotted"), std::string::npos);
  const Page run = Route(**archive, db, "/run/" + kRun, {});
  EXPECT_EQ(run.status, 200);
}

TEST(WebServerTest, AnAddressBeyondThisHostNeedsAToken) {
  testing::TempDir dir("web_listen");
  ServeOptions o;
  o.db_path = MakeArchive(dir);
  ASSERT_TRUE(ParseListen("0.0.0.0:0", &o).ok());
  auto s = WebServer::Start(o);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("needs --token"), std::string::npos);
  EXPECT_TRUE(IsLoopback("127.0.0.1"));
  EXPECT_TRUE(IsLoopback("127.1.2.3"));
  EXPECT_TRUE(IsLoopback("::1"));
  EXPECT_FALSE(IsLoopback("10.0.0.1"));
  EXPECT_FALSE(IsLoopback("0.0.0.0"));
  ServeOptions p;
  EXPECT_TRUE(ParseListen("8081", &p).ok());
  EXPECT_EQ(p.host, "127.0.0.1");
  EXPECT_EQ(p.port, 8081);
  EXPECT_TRUE(ParseListen("[::1]:9000", &p).ok());
  EXPECT_EQ(p.host, "::1");
  EXPECT_FALSE(ParseListen("host:http", &p).ok());
  EXPECT_FALSE(ParseListen("1.2.3.4:70000", &p).ok());
  o.host = "127.0.0.1";
  o.token = "short";
  auto weak = WebServer::Start(o);
  ASSERT_FALSE(weak.ok());
  EXPECT_NE(weak.status().message().find("at least 12"), std::string::npos);
  o.token = "has;semicolon-in-it";
  EXPECT_FALSE(WebServer::Start(o).ok());
  o.token.clear();
  o.db_path = dir.path("missing.db");
  o.host = "127.0.0.1";
  auto missing = WebServer::Start(o);
  EXPECT_FALSE(missing.ok());
}

// A finished lot's report is kept, and made again once the archive changes it.
TEST_F(WebTest, AFinishedLotsReportIsKeptUntilTheArchiveChangesIt) {
  Serve();
  const std::string path = "/lot/" + Encode(kLot);
  auto first = client_->Get(path);
  ASSERT_TRUE(first);
  ASSERT_EQ(first->status, 200);
  // A change the fingerprint does not cover (an operator's name rewritten
  // behind the archive's back): the kept page is served, without it.
  {
    auto w = store::Archive::Open(db_, store::Archive::Mode::kWrite);
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE(
        (*w)->db().Exec("UPDATE runs SET operator = 'CHANGED-OP' WHERE run_id = 'R-1'").ok());
  }
  auto again = client_->Get(path);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->body, first->body);
  EXPECT_EQ(again->body.find("CHANGED-OP"), std::string::npos);
  auto fingerprint = [&] {
    auto a = store::Archive::Open(db_, store::Archive::Mode::kRead);
    EXPECT_TRUE(a.ok());
    auto f = LotReportFingerprint(**a, kLot);
    EXPECT_TRUE(f.ok());
    return *f;
  };
  const std::string before = fingerprint();
  EXPECT_FALSE(before.empty());
  // A second unit's run in the lot, open: nothing is kept while it runs.
  auto a = store::Archive::Open(db_, store::Archive::Mode::kWrite);
  ASSERT_TRUE(a.ok());
  store::RunInfo r = OneAxisRun("R-2", "SECOND-UNIT", kLot, 1'800'000'100'000'000);
  r.slot = "A2";
  auto key = (*a)->UpsertRun(r);
  ASSERT_TRUE(key.ok());
  EXPECT_EQ(fingerprint(), "");
  auto running = client_->Get(path);
  ASSERT_TRUE(running);
  EXPECT_NE(running->body.find("SECOND-UNIT"), std::string::npos);
  // Finished: a new fingerprint, a new report.
  store::ResultRecord res;
  res.verdict = "PASS";
  Finish(**a, *key, r, res);
  const std::string after = fingerprint();
  EXPECT_FALSE(after.empty());
  EXPECT_NE(after, before);
  auto finished = client_->Get(path);
  ASSERT_TRUE(finished);
  EXPECT_NE(finished->body.find("SECOND-UNIT"), std::string::npos);
  EXPECT_NE(finished->body.find("CHANGED-OP"), std::string::npos);
}

// Names that are dot segments ("." and "..": valid identifiers) are linked
// in the query form, which a browser does not resolve away, and served.
TEST(WebPagesTest, DotNamesAreLinkedAndServedInTheQueryForm) {
  testing::TempDir dir("web_dots");
  const std::string db = dir.path("dots.db");
  {
    auto a = store::Archive::Open(db, store::Archive::Mode::kWrite);
    ASSERT_TRUE(a.ok());
    const store::RunInfo r = OneAxisRun(".", "..", "..", 1'800'000'000'000'000);
    auto key = (*a)->UpsertRun(r);
    ASSERT_TRUE(key.ok());
    store::ResultRecord res;
    res.verdict = "PASS";
    Finish(**a, *key, r, res);
  }
  auto archive = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok());
  const Page home = Route(**archive, db, "/", {});
  EXPECT_NE(home.body.find("href=\"/lot?name=..\""), std::string::npos) << home.body;
  const Page lot = Route(**archive, db, "/lot", {{"name", ".."}});
  EXPECT_EQ(lot.status, 200);
  const Page unit = Route(**archive, db, "/unit", {{"serial", ".."}});
  EXPECT_EQ(unit.status, 200);
  EXPECT_NE(unit.body.find("href=\"/run?id=.\""), std::string::npos) << unit.body;
  const Page run = Route(**archive, db, "/run", {{"id", "."}});
  EXPECT_EQ(run.status, 200);
  EXPECT_NE(run.body.find("href=\"/unit?serial=..\""), std::string::npos);
  EXPECT_NE(run.body.find("href=\"/api/run?id=.\""), std::string::npos);
  EXPECT_EQ(Route(**archive, db, "/api/run", {{"id", "."}}).status, 200);
  EXPECT_EQ(Route(**archive, db, "/api/lot", {{"name", ".."}}).status, 200);
  EXPECT_EQ(Route(**archive, db, "/lot", {}).status, 404);
}

// The live page: a station bus heard, its runs, verdicts and curves served
// as JSON and as server-sent events; the archive may come later.
TEST(LiveServeTest, ABusHeardIsServedAsJsonAndEvents) {
  testing::TempDir dir("web_live");
  const std::string url =
      "udpm://239.255.76.67:" + std::to_string(31000 + ::getpid() % 2000) + "?ttl=0";
  ServeOptions o;
  o.db_path = dir.path("not-yet.db");  // the station creates it later
  o.port = 0;
  o.bus_url = url;
  TestServer server(o);
  ASSERT_TRUE(server.ok());
  httplib::Client& client = server.client();
  auto page = client.Get("/live");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("new EventSource('/live/events')"), std::string::npos);
  EXPECT_NE(page->get_header_value("Content-Security-Policy").find("connect-src 'self'"),
            std::string::npos);
  auto home = client.Get("/");
  ASSERT_TRUE(home);
  EXPECT_EQ(home->status, 503);
  EXPECT_NE(home->body.find("does not exist yet"), std::string::npos);

  // A station on the bus: a unit whose serial tries HTML, its run, a
  // provisional result and an interim curve, and the processes' status.
  RoleBuses bus(url);
  ASSERT_TRUE(bus.ok());
  const std::string serial = "U<b>1";
  imuqual::run_t r{};
  r.run_id = "P-" + serial;
  r.unit_serial = serial;
  r.slot = "A1";
  r.lot = "LOT-1";
  r.station = "bench-9";
  r.source = "sim:vg700";
  r.announcer = "acquire";
  r.state = imuqual::run_t::STATE_RUNNING;
  r.nominal_rate_hz = 100;
  r.samples_published = 6000;
  r.start_utime = 1;
  r.num_axes = 1;
  r.axis_names = {"gx"};
  r.axis_kinds = {imuqual::rate_batch_t::KIND_GYRO};
  imuqual::unit_result_t res{};
  res.run_id = r.run_id;
  res.unit_serial = serial;
  res.host_utime = 123456789;
  imuqual::measurement_t m{};
  m.axis = "gx";
  m.name = "bias_instability";
  m.value = 12.5;
  m.uncertainty = 0.75;
  m.unit = "deg/h";
  m.outcome = imuqual::measurement_t::OUTCOME_FAIL;
  res.measurements = {m};
  res.num_measurements = 1;
  imuqual::allan_curve_t c{};
  c.run_id = r.run_id;
  c.unit_serial = serial;
  c.axis = "gx";
  c.axis_kind = imuqual::rate_batch_t::KIND_GYRO;
  c.estimator = "oadev";
  c.host_utime = 5;
  c.samples = 6000;
  c.tau_s = {0.01, 0.1, 1};
  c.dev = {0.1, 0.03, 0.01};
  c.lo = {0.09, 0.027, 0.009};
  c.hi = {0.11, 0.033, 0.011};
  c.m = {1, 10, 100};
  c.edf = {100, 50, 10};
  c.n_terms = {1000, 900, 100};
  c.stride = {1, 1, 1};
  c.alpha = {0, 0, 0};
  c.alpha_inherited = {false, false, false};
  c.num_points = 3;
  imuqual::status_t st{};
  st.process = "store";
  st.instance = "h:42";
  st.healthy = 1;
  nlohmann::json live;
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(bus.acquire().Publish(channels::kRun, r).ok());
    ASSERT_TRUE(bus.analyze().Publish(channels::Result(serial), res).ok());
    ASSERT_TRUE(bus.analyze().Publish(channels::Curve(serial), c).ok());
    ASSERT_TRUE(bus.acquire().Publish(channels::kStatus, st).ok());
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    auto got = client.Get("/api/live");
    ASSERT_TRUE(got);
    live = nlohmann::json::parse(got->body);
    if (!live["units"].empty() &&
        !live["units"][0]["axes"][0]["verdict"].get<std::string>().empty())
      break;
  }
  ASSERT_EQ(live["units"].size(), 1u) << live.dump();
  const auto& u = live["units"][0];
  EXPECT_EQ(u["serial"], serial);
  EXPECT_EQ(u["slot"], "A1");
  EXPECT_EQ(u["state"], "running");
  EXPECT_EQ(u["elapsed"], "1:00");
  EXPECT_EQ(u["verdict"], "fail?");
  EXPECT_EQ(u["axes"][0]["bias_instability"], "12.5 \u00b1 0.75 deg/h");
  EXPECT_EQ(live["station"], "bench-9");
  EXPECT_EQ(live["lot"], "LOT-1");
  EXPECT_EQ(live["newest_utime"], 123456789);
  EXPECT_EQ(live["processes"][0]["name"], "store");
  EXPECT_EQ(live["processes"][0]["running"], 1);
  // The curve, in deg/h.
  auto curves = client.Get("/api/live/curves?run=" + std::string("P-U%3Cb%3E1"));
  ASSERT_TRUE(curves);
  const nlohmann::json cj = nlohmann::json::parse(curves->body);
  ASSERT_EQ(cj.size(), 1u) << curves->body;
  EXPECT_EQ(cj[0]["unit"], "deg/h");
  EXPECT_DOUBLE_EQ(cj[0]["dev"][0].get<double>(), 360.0);
  // The event stream: a status and the curve, then the client goes away.
  std::string stream;
  auto events = client.Get("/live/events", [&](const char* data, size_t n) {
    stream.append(data, n);
    return stream.find("event: curve") == std::string::npos ||
           stream.find("event: status") == std::string::npos;
  });
  EXPECT_NE(stream.find("event: status\ndata: {"), std::string::npos) << stream;
  EXPECT_NE(stream.find("event: curve\ndata: {"), std::string::npos) << stream;
}

// A soak heard to its end: its lot's report is built before anyone asks.
TEST(LiveServeTest, TheReportOfASoakOverIsBuiltAtOnce) {
  testing::TempDir dir("web_warm");
  ServeOptions o;
  o.db_path = MakeArchive(dir);  // lot kLot: run kRun finished
  o.port = 0;
  o.bus_url = "udpm://239.255.76.67:" + std::to_string(33000 + ::getpid() % 2000) + "?ttl=0";
  TestServer server(o);
  ASSERT_TRUE(server.ok());
  RoleBuses bus(o.bus_url);
  ASSERT_TRUE(bus.ok());
  imuqual::run_t r{};
  r.run_id = kRun;
  r.unit_serial = kSerial;
  r.lot = kLot;
  r.announcer = "acquire";
  r.state = imuqual::run_t::STATE_COMPLETE;
  r.start_utime = 1;
  imuqual::unit_result_t res{};
  res.run_id = kRun;
  res.unit_serial = kSerial;
  res.is_final = true;
  res.verdict = imuqual::measurement_t::OUTCOME_FAIL;
  imuqual::ack_t ack{};
  ack.process = "store";
  ack.run_id = kRun;
  ack.run_done = true;
  EXPECT_EQ(server.server().ReportsKept(), 0u);
  for (int i = 0; i < 100 && server.server().ReportsKept() == 0; ++i) {
    ASSERT_TRUE(bus.acquire().Publish(channels::kRun, r).ok());
    ASSERT_TRUE(bus.analyze().Publish(channels::Result(kSerial), res).ok());
    ASSERT_TRUE(bus.store().Publish(channels::kAck, ack).ok());
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_EQ(server.server().ReportsKept(), 1u);
}

TEST(LiveServeTest, WithoutABusTheLivePageSaysHowToStartIt) {
  testing::TempDir dir("web_nobus");
  ServeOptions o;
  o.db_path = MakeArchive(dir);
  o.port = 0;
  TestServer server(o);
  ASSERT_TRUE(server.ok());
  httplib::Client& client = server.client();
  auto page = client.Get("/live");
  ASSERT_TRUE(page);
  EXPECT_NE(page->body.find("--bus URL"), std::string::npos);
  EXPECT_EQ(page->body.find("EventSource"), std::string::npos);
  auto api = client.Get("/api/live");
  ASSERT_TRUE(api);
  EXPECT_EQ(api->status, 404);
  auto events = client.Get("/live/events");
  ASSERT_TRUE(events);
  EXPECT_EQ(events->status, 404);
}

}  // namespace
}  // namespace imuqual::web
