// imuqual serve, in-process on a loopback port: the pages agree with the
// archive and with the report's own code, hostile strings are inert, the
// server only reads, a token guards it when asked (also over TLS), no
// inline script runs, a port in use is an error, a request head that never
// ends is cut; the back-off of token guessers and the log of what clients
// did, on a simulated clock.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "analyze/judge/measurements.h"
#include "common/channels.h"
#include "common/lcm_bus.h"
#include "common/strings.h"
#include "common/text_util.h"
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
#include "store/query.h"
#include "store/run_record.h"
#include "tests/test_util.h"
#include "web/access.h"
#include "web/live_feed.h"
#include "web/live_page.h"
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
  // The served page leaves its slow sections (noise models, plots) to its
  // script, which fetches each from /lot-section?name=LOT&part=PART.
  report::LotReportOptions served_options;
  served_options.section_url = [](const std::string& part) {
    return "/lot-section?name=" + Encode(kLot) + "&part=" + part;
  };
  served_options.site_navigation = SiteNavigation();
  // ... with the site's navigation: a lot page leads back to the lot list.
  EXPECT_NE(lot->body.find("<nav class=\"site\"><a href=\"/\">imuqual: lots</a>"),
            std::string::npos);
  auto report = report::BuildLotReportHtml(**archive, kLot, db_, served_options);
  ASSERT_TRUE(report.ok());
  auto data = report::LoadLotReport(**archive, kLot);
  ASSERT_TRUE(data.ok());
  auto standalone = report::BuildLotReportHtml(**archive, kLot, db_);
  ASSERT_TRUE(standalone.ok());
  EXPECT_EQ(standalone->find("data-src="), std::string::npos);
  for (const std::string part : {"lot-model", "lot-plots", "unit-plots"}) {
    auto section = report::RenderLotSection(*data, part);
    ASSERT_TRUE(section.ok()) << part;
    EXPECT_NE(section->find("<section id=\"" + part + "\">"), std::string::npos) << *section;
    auto fetched = client_->Get("/lot-section?name=" + Encode(kLot) + "&part=" + part);
    ASSERT_TRUE(fetched);
    EXPECT_EQ(fetched->status, 200);
    EXPECT_EQ(fetched->body, *section) << part;
    // A report file holds the same section itself.
    EXPECT_NE(standalone->find(*section), std::string::npos) << part;
    EXPECT_NE(report->find("data-src=\"/lot-section?name=" + Encode(kLot) + "&amp;part=" + part),
              std::string::npos)
        << part;
  }
  auto unknown = client_->Get("/lot-section?name=" + Encode(kLot) + "&part=secrets");
  ASSERT_TRUE(unknown);
  EXPECT_EQ(unknown->status, 404);
  auto strip_time = [](std::string s) {  // the report says when it was generated
    const size_t at = s.find(" on 20");
    return at == std::string::npos ? s : s.substr(0, at);
  };
  // ... its script served as a file (no inline script runs here).
  std::string served = *report;
  const std::string inline_script =
      "<script>" + std::string(report::LotReportScript()) + "</script>";
  ASSERT_NE(served.find(inline_script), std::string::npos);
  served.replace(served.find(inline_script), inline_script.size(),
                 "<script src=\"/assets/report.js\"></script>");
  EXPECT_EQ(strip_time(lot->body), strip_time(served));
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
  // The start of a serial finds the unit it can only be (a line types the
  // start, or a lot's prefix); no unit starting so: 404 naming it.
  auto prefix = client_->Get("/unit?serial=" + Encode(kSerial.substr(0, 3)));
  ASSERT_TRUE(prefix);
  EXPECT_EQ(prefix->status, 200);
  EXPECT_NE(prefix->body.find("href=\"/run/R-1\""), std::string::npos) << prefix->body;
  auto none = client_->Get("/unit?serial=ZZZ");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 404);
  EXPECT_NE(none->body.find("starting with it"), std::string::npos) << none->body;
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
  EXPECT_NE(compare->body.find("<strong>0 of "), std::string::npos) << compare->body;
  EXPECT_EQ(compare->body.find("<tr class=\"sig\">"), std::string::npos);  // nothing differs
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

// A unit that passes but whose record moved (a qualifier-only stationarity
// event) is listed among the units that need a look, after the failing
// ones, with its reasons; a passing unit without events is not.
TEST(WebPagesTest, AUnitWhoseRecordMovedNeedsALook) {
  testing::TempDir dir("web_moved");
  const std::string db = dir.path("moved.db");
  const std::string lot = "LOT-MOVED";
  {
    auto a = store::Archive::Open(db, store::Archive::Mode::kWrite);
    ASSERT_TRUE(a.ok());
    const auto add = [&](const std::string& run_id, const std::string& serial,
                         const std::string& verdict, double events, int64_t start) {
      store::RunInfo r = OneAxisRun(run_id, serial, lot, start);
      auto key = (*a)->UpsertRun(r);
      ASSERT_TRUE(key.ok());
      store::ResultRecord res;
      res.verdict = verdict;
      pb::Measurement count = judge::NewMeasurement("gx", judge::kStationarityEvents, events, "1",
                                                    events > 0 ? "1 event: level step" : "none");
      res.measurements.push_back(count);
      if (events > 0) res.reasons = {"gx: 1 stationarity event (qualifier only): level step"};
      if (verdict == "FAIL") res.reasons.push_back("gx: bias_instability above high limit");
      Finish(**a, *key, r, res);
    };
    add("R-STILL", "U-STILL", "PASS", 0, 1'800'000'000'000'000);
    add("R-MOVED", "U-MOVED", "PASS", 1, 1'800'000'010'000'000);
    add("R-FAIL", "U-FAIL", "FAIL", 0, 1'800'000'020'000'000);
  }
  auto archive = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok());
  auto html = report::BuildLotReportHtml(**archive, lot, db);
  ASSERT_TRUE(html.ok()) << html.status().ToString();
  const size_t section = html->find("<section id=\"attention\">");
  ASSERT_NE(section, std::string::npos);
  const std::string attention = html->substr(section, html->find("</section>", section) - section);
  const size_t failing = attention.find("data-serial=\"U-FAIL\"");
  const size_t moved = attention.find("data-serial=\"U-MOVED\"");
  EXPECT_NE(failing, std::string::npos) << attention;
  EXPECT_NE(moved, std::string::npos) << attention;
  EXPECT_LT(failing, moved) << "the failing unit first";
  EXPECT_NE(attention.find("1 stationarity event (qualifier only)"), std::string::npos);
  EXPECT_EQ(attention.find("U-STILL"), std::string::npos) << attention;
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
  // The unit's plots are the page's deferred section.
  const Page plots = Route(**archive, db, "/lot-section", {{"name", kLot}, {"part", "unit-plots"}});
  EXPECT_EQ(plots.status, 200);
  EXPECT_NE(plots.body.find("raw samples not plotted"), std::string::npos);
  EXPECT_NE(plots.body.find("dynamic Allan deviation not drawn"), std::string::npos);
  const Page run = Route(**archive, db, "/run/" + kRun, {});
  EXPECT_EQ(run.status, 200);
  EXPECT_NE(run.body.find("Dynamic Allan deviation not drawn"), std::string::npos);
}

TEST(WebServerTest, AnAddressBeyondThisHostNeedsAToken) {
  testing::TempDir dir("web_listen");
  ServeOptions o;
  o.db_path = MakeArchive(dir);
  ASSERT_TRUE(ParseListen("0.0.0.0:0", &o).ok());
  auto s = WebServer::Start(o);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("needs a token (--token-file FILE, --new-token, or --token"),
            std::string::npos)
      << s.status().message();
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
    auto f = store::QueryLotFingerprint(**a, kLot);
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
  EXPECT_NE(page->body.find("<script src=\"/assets/live.js\">"), std::string::npos);
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
    ASSERT_TRUE(bus.store().Publish(channels::kStatus, st).ok());
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    auto got = client.Get("/api/live");
    ASSERT_TRUE(got);
    live = nlohmann::json::parse(got->body);
    // The unit's verdict and the store's status (the processes line is
    // rebuilt on the monitor's tick, which may come after the verdict).
    if (!live["units"].empty() &&
        !live["units"][0]["axes"][0]["verdict"].get<std::string>().empty() &&
        !live["processes"].empty() && live["processes"][0]["running"] == 1)
      break;
  }
  ASSERT_EQ(live["units"].size(), 1u) << live.dump();
  const auto& u = live["units"][0];
  EXPECT_EQ(u["serial"], serial);
  EXPECT_EQ(u["slot"], "A1");
  EXPECT_EQ(u["state"], "running");
  EXPECT_EQ(u["elapsed"], "1:00");
  EXPECT_EQ(u["verdict"], "fail?");
  EXPECT_EQ(u["axes"][0]["bias_instability"], "12.50 \u00b1 0.75 deg/h");
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
  ack.num_runs = 1;
  ack.run_ids = {kRun};
  ack.next_seq = {0};
  ack.run_done = {true};
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

// A self-signed certificate for 127.0.0.1 and its key, made by the openssl
// command (the test's, not the server's code).
struct TestCertificate {
  std::string cert, key;
};
TestCertificate MakeCertificate(const testing::TempDir& dir, const std::string& name) {
  TestCertificate c{dir.path(name + "-cert.pem"), dir.path(name + "-key.pem")};
  const auto made = testing::RunCommand(
      "openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 2 -subj "
      "/CN=127.0.0.1 -addext subjectAltName=IP:127.0.0.1 -keyout " +
      c.key + " -out " + c.cert + " 2>&1 && chmod 600 " + c.key);
  EXPECT_EQ(made.exit_code, 0) << made.output;
  return c;
}

// The policy: scripts from this server only, nothing from elsewhere, no
// inline script; the pages' scripts are served as files and still there.
TEST_F(WebTest, NoInlineScriptRunsAndThePagesScriptsAreFiles) {
  Serve();
  auto home = client_->Get("/");
  ASSERT_TRUE(home);
  EXPECT_EQ(home->get_header_value("Content-Security-Policy"),
            "default-src 'none'; script-src 'self'; style-src 'unsafe-inline'; img-src data:; "
            "connect-src 'self'; form-action 'self'; base-uri 'none'; frame-ancestors 'none'");
  // The lot page: the report, its script as a file (the report file keeps it inline).
  auto lot = client_->Get("/lot/" + Encode(kLot));
  ASSERT_TRUE(lot);
  ASSERT_EQ(lot->status, 200);
  EXPECT_NE(lot->body.find("<script src=\"/assets/report.js\"></script>"), std::string::npos);
  EXPECT_EQ(lot->body.find("<script>"), std::string::npos);
  auto report_js = client_->Get("/assets/report.js");
  ASSERT_TRUE(report_js);
  EXPECT_EQ(report_js->status, 200);
  EXPECT_EQ(report_js->get_header_value("Content-Type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(report_js->body, std::string(report::LotReportScript()));
  EXPECT_NE(report_js->body.find("table.sortable"), std::string::npos);
  auto archive = store::Archive::Open(db_, store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok());
  auto file = report::BuildLotReportHtml(**archive, kLot, db_);
  ASSERT_TRUE(file.ok());
  EXPECT_NE(file->find("<script>" + std::string(report::LotReportScript()) + "</script>"),
            std::string::npos);
}

TEST(LiveServeTest, TheLivePagesScriptIsAFile) {
  testing::TempDir dir("web_live_js");
  ServeOptions o;
  o.db_path = MakeArchive(dir);
  o.port = 0;
  o.bus_url = "udpm://239.255.76.67:" + std::to_string(35000 + ::getpid() % 2000) + "?ttl=0";
  TestServer server(o);
  ASSERT_TRUE(server.ok());
  auto page = server.client().Get("/live");
  ASSERT_TRUE(page);
  EXPECT_NE(page->body.find("<script src=\"/assets/live.js\"></script>"), std::string::npos);
  EXPECT_EQ(page->body.find("<script>"), std::string::npos);
  auto js = server.client().Get("/assets/live.js");
  ASSERT_TRUE(js);
  EXPECT_EQ(js->status, 200);
  EXPECT_EQ(js->body, LivePageScript());
  EXPECT_NE(js->body.find("new EventSource('/live/events')"), std::string::npos);
}

// Over TLS with a token: the right token by header, by ?token= (which sets
// a Secure, HttpOnly, SameSite=Strict cookie) and by that cookie; nothing
// without it; plain HTTP to the TLS port gets a hint, not the archive.
TEST_F(WebTest, OverTlsTheTokenWorksByHeaderQueryAndSecureCookie) {
  const TestCertificate c = MakeCertificate(dir_, "tls");
  ServeOptions o;
  o.db_path = db_;
  o.port = 0;
  o.token = "tls-token-0123456789";
  o.tls_cert_path = c.cert;
  o.tls_key_path = c.key;
  auto s = WebServer::Start(o);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_TRUE((*s)->tls());
  std::thread serving([&] { (*s)->Run(); });
  struct Joiner {
    WebServer* server;
    std::thread* thread;
    ~Joiner() {
      server->Stop();
      thread->join();
    }
  } joiner{s->get(), &serving};
  httplib::SSLClient client("127.0.0.1", (*s)->port());
  client.set_ca_cert_path(c.cert.c_str());
  client.enable_server_certificate_verification(true);
  auto none = client.Get("/api/lots");
  ASSERT_TRUE(none) << httplib::to_string(none.error());
  EXPECT_EQ(none->status, 401);
  auto header = client.Get("/api/lots", {{"Authorization", "Bearer tls-token-0123456789"}});
  ASSERT_TRUE(header);
  EXPECT_EQ(header->status, 200);
  EXPECT_NE(header->body.find("\"lot\""), std::string::npos) << header->body;
  auto query = client.Get("/?token=tls-token-0123456789");
  ASSERT_TRUE(query);
  EXPECT_EQ(query->status, 200);
  const std::string cookie = query->get_header_value("Set-Cookie");
  EXPECT_EQ(cookie,
            "imuqual_token=tls-token-0123456789; Path=/; HttpOnly; SameSite=Strict; Secure");
  auto with_cookie = client.Get("/run/" + kRun, {{"Cookie", "imuqual_token=tls-token-0123456789"}});
  ASSERT_TRUE(with_cookie);
  EXPECT_EQ(with_cookie->status, 200);
  auto script = client.Get("/assets/report.js", {{"Cookie", "imuqual_token=tls-token-0123456789"}});
  ASSERT_TRUE(script);
  EXPECT_EQ(script->status, 200);
  // Someone typing http:// for https://: a hint in plain text, nothing else.
  httplib::Client plain("127.0.0.1", (*s)->port());
  auto hint = plain.Get("/api/lots", {{"Authorization", "Bearer tls-token-0123456789"}});
  ASSERT_TRUE(hint);
  EXPECT_EQ(hint->status, 400);
  EXPECT_NE(hint->body.find("https://"), std::string::npos);
  EXPECT_EQ(hint->body.find("lot"), std::string::npos);
}

// Plain HTTP keeps the cookie without Secure (loopback: no TLS to mark it for).
TEST_F(WebTest, WithoutTlsTheCookieIsNotSecure) {
  Serve("plain-token-0123456789");
  auto query = client_->Get("/?token=plain-token-0123456789");
  ASSERT_TRUE(query);
  EXPECT_EQ(query->get_header_value("Set-Cookie"),
            "imuqual_token=plain-token-0123456789; Path=/; HttpOnly; SameSite=Strict");
}

// Every option error is one line naming what is wrong, before anything binds.
TEST(WebServerTest, TlsAndTransportErrorsNameTheFileOrOption) {
  testing::TempDir dir("web_tls_errors");
  const TestCertificate good = MakeCertificate(dir, "good");
  const TestCertificate other = MakeCertificate(dir, "other");
  ServeOptions o;
  o.db_path = MakeArchive(dir);
  o.port = 0;
  auto error = [&](const ServeOptions& opts) {
    auto s = WebServer::Start(opts);
    EXPECT_FALSE(s.ok());
    const std::string m = s.ok() ? "" : s.status().message();
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    return m;
  };
  // Beyond loopback: plain HTTP only when asked for, naming both ways.
  o.host = "0.0.0.0";
  o.token = "lan-token-0123456789";
  std::string m = error(o);
  EXPECT_NE(m.find("--tls-cert FILE --tls-key FILE"), std::string::npos) << m;
  EXPECT_NE(m.find("--insecure-http"), std::string::npos) << m;
  o.host = "127.0.0.1";
  o.tls_cert_path = good.cert;
  m = error(o);
  EXPECT_NE(m.find("go together"), std::string::npos) << m;
  o.tls_key_path = good.key;
  o.insecure_http = true;
  m = error(o);
  EXPECT_NE(m.find("contradict"), std::string::npos) << m;
  o.insecure_http = false;
  o.tls_cert_path = dir.path("missing.pem");
  m = error(o);
  EXPECT_NE(m.find("--tls-cert " + dir.path("missing.pem")), std::string::npos) << m;
  EXPECT_NE(m.find("No such file"), std::string::npos) << m;
  o.tls_cert_path = o.db_path;  // not PEM
  m = error(o);
  EXPECT_NE(m.find("--tls-cert " + o.db_path + ": not a PEM certificate"), std::string::npos) << m;
  o.tls_cert_path = good.cert;
  ASSERT_EQ(::chmod(good.cert.c_str(), 0600), 0);  // owner-only, as a key must be
  o.tls_key_path = good.cert;                      // a certificate, not a key
  m = error(o);
  EXPECT_NE(m.find("--tls-key " + good.cert + ": not an unencrypted PEM private key"),
            std::string::npos)
      << m;
  o.tls_key_path = other.key;
  m = error(o);
  EXPECT_NE(m.find("--tls-key " + other.key + ": not the key of the certificate in " + good.cert),
            std::string::npos)
      << m;
  ASSERT_EQ(::chmod(good.key.c_str(), 0644), 0);
  o.tls_key_path = good.key;
  m = error(o);
  EXPECT_NE(m.find("--tls-key " + good.key + ": a private key readable by anyone (mode 0644)"),
            std::string::npos)
      << m;
  ASSERT_EQ(::chmod(good.key.c_str(), 0600), 0);
  auto fine = WebServer::Start(o);
  EXPECT_TRUE(fine.ok()) << fine.status().ToString();
}

// A port in use is an error, never a second listener.
TEST(WebServerTest, APortInUseIsAnError) {
  testing::TempDir dir("web_port");
  ServeOptions o;
  o.db_path = MakeArchive(dir);
  o.port = 0;
  auto first = WebServer::Start(o);
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  o.port = (*first)->port();
  auto second = WebServer::Start(o);
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.status().code(), Status::Code::kUnavailable);
  EXPECT_EQ(second.status().message(),
            "serve: cannot listen on 127.0.0.1:" + std::to_string(o.port) +
                ": the port is in use (another server listens there: stop it, or choose another "
                "--listen port)");
}

// GIVEN a connection that sends a header line every 100 ms, never the end
// WHEN  the head deadline passes
// THEN  the server closes it although it never stopped sending, and another
//       client is answered meanwhile.
TEST_F(WebTest, AConnectionThatNeverFinishesItsRequestIsClosed) {
  Serve();
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(server_->server().port()));
  inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof(to)), 0);
  const std::string opening = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n";
  ASSERT_GT(::send(fd, opening.data(), opening.size(), MSG_NOSIGNAL), 0);
  auto other = client_->Get("/api/lots");
  ASSERT_TRUE(other);
  EXPECT_EQ(other->status, 200);
  bool closed = false;
  // The deadline is 5 s after the accept; 30 s bounds the wait on a loaded machine.
  for (int i = 0; i < 300 && !closed; ++i) {
    const std::string line = "X-Slow: " + std::to_string(i) + "\r\n";
    (void)!::send(fd, line.data(), line.size(), MSG_NOSIGNAL);
    pollfd p{fd, POLLIN | POLLRDHUP, 0};
    closed = ::poll(&p, 1, 100) > 0;
  }
  ::close(fd);
  EXPECT_TRUE(closed);
  EXPECT_EQ(server_->server().GateCounts().closed_at_deadline, 1u);
}

// The back-off of a client guessing tokens, on a simulated clock: the
// guesses that are looked at collapse; another client is unaffected.
TEST(TokenThrottleTest, GuessesCollapseToTheBackoffSchedule) {
  TokenThrottle t;
  // GIVEN guesses every millisecond for 1000 s (a million attempts)
  // WHEN  each one is looked at only when the client need not wait
  // THEN  5 free ones, then one per back-off: 1, 2, 4, ... 256, then 300 s.
  int looked_at = 0;
  std::vector<double> waits;
  for (int ms = 0; ms < 1'000'000; ++ms) {
    const double now_s = ms / 1000.0;
    if (t.WaitS("10.0.0.9", now_s) > 0) continue;
    ++looked_at;
    const double wait_s = t.Failed("10.0.0.9", now_s);
    if (wait_s > 0) waits.push_back(wait_s);
  }
  // Waits 1..256 s sum to 511 s; the rest of the 1000 s goes in 300 s steps.
  const std::vector<double> expected = {1, 2, 4, 8, 16, 32, 64, 128, 256, 300, 300};
  EXPECT_EQ(waits, expected);
  EXPECT_EQ(looked_at, 5 + static_cast<int>(expected.size()));
  EXPECT_EQ(t.Failures("10.0.0.9"), looked_at);
  // Another client is looked at at once; the guessing one still waits.
  EXPECT_EQ(t.WaitS("10.0.0.10", 999.0), 0);
  EXPECT_GT(t.WaitS("10.0.0.9", 999.0), 0);
  // A right token clears the count; a client quiet for kForgetS is forgotten.
  t.Succeeded("10.0.0.9");
  EXPECT_EQ(t.Failures("10.0.0.9"), 0);
  t.Failed("10.0.0.11", 0);
  t.Failed("10.0.0.12", TokenThrottle::kForgetS + 1);
  EXPECT_EQ(t.Failures("10.0.0.11"), 0);
  EXPECT_EQ(t.Failures("10.0.0.12"), 1);
}

TEST(ClientLogTest, OneLinePerClientAndPeriodWithCountsAndNoToken) {
  std::vector<std::string> lines;
  ClientLog log([&](const std::string& line) { lines.push_back(line); });
  // The first event at once.
  log.Note("10.0.0.7", ClientLog::Event::kWrongToken, 100);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "serve: client 10.0.0.7: 1 wrong token");
  // Then summed for the period, per client.
  for (int i = 0; i < 5; ++i) log.Note("10.0.0.7", ClientLog::Event::kWrongToken, 101 + i);
  for (int i = 0; i < 290; ++i)
    log.Note("10.0.0.7", ClientLog::Event::kRefusedBackingOff, 110 + i * 0.1);
  log.Note("10.0.0.8", ClientLog::Event::kOverConnectionCap, 120);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[1], "serve: client 10.0.0.8: 1 connection refused at once (too many open)");
  log.Flush(150, /*all=*/false);  // not a period since the last line
  EXPECT_EQ(lines.size(), 2u);
  log.Flush(160, /*all=*/false);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[2],
            "serve: client 10.0.0.7: 5 wrong tokens, 290 requests refused while it backs off "
            "(429) within 59 s");
  // On stop, whatever is counted.
  log.Note("10.0.0.7", ClientLog::Event::kHeadDeadline, 170);
  log.Note("10.0.0.7", ClientLog::Event::kTlsFailed, 171);
  log.Flush(172, /*all=*/true);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[3],
            "serve: client 10.0.0.7: 1 connection closed without a complete request in time, "
            "1 TLS handshake failed within 2 s");
}

TEST(AccessTest, ClientKeysTokensAndTokenFiles) {
  EXPECT_EQ(ClientKey("10.1.2.3"), "10.1.2.3");
  EXPECT_EQ(ClientKey("::ffff:10.1.2.3"), "10.1.2.3");
  EXPECT_EQ(ClientKey("2001:db8:1:2:aaaa:bbbb:cccc:dddd"), "2001:db8:1:2::/64");
  EXPECT_EQ(ClientKey("2001:db8:1:2::5"), ClientKey("2001:db8:1:2:ffff::1"));
  EXPECT_NE(ClientKey("2001:db8:1:2::5"), ClientKey("2001:db8:1:3::5"));
  auto a = NewToken();
  auto b = NewToken();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->size(), 43u);  // 256 bits in base64url without padding
  EXPECT_EQ(
      a->find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_"),
      std::string::npos);
  EXPECT_NE(*a, *b);
  EXPECT_TRUE(CheckToken(*a).ok());
  EXPECT_FALSE(CheckToken("short").ok());
  EXPECT_FALSE(CheckToken("has;semicolon-in-it").ok());
  testing::TempDir dir("web_token_file");
  const std::string path = dir.path("token");
  ::umask(022);
  ASSERT_TRUE(WriteNewTokenFile(path, *a).ok());
  struct stat info {};
  ASSERT_EQ(::stat(path.c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 0777, 0600u);
  auto text = ReadFileToString(path);
  ASSERT_TRUE(text.ok());
  EXPECT_EQ(*text, *a + "\n");
  const Status again = WriteNewTokenFile(path, *b);
  EXPECT_FALSE(again.ok());
  EXPECT_NE(again.message().find(path + " exists already"), std::string::npos) << again.message();
  EXPECT_EQ(*ReadFileToString(path), *a + "\n");  // untouched
}

}  // namespace
}  // namespace imuqual::web
