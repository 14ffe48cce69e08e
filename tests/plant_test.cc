// The plant archive end to end: two stations, each in a network namespace
// of its own, soak lots (one lot split across both), then ship to a
// PostgreSQL cluster this test starts (scripts/pg-throwaway: a temporary
// data directory, a Unix socket only, fsync off, a non-root user). At the
// plant every run's rows (its runs row, axes, raw chunks, gaps, curves and
// points, measurements), its lot and unit and its chain entries equal the
// station's bit for bit; reanalyze --check holds at the plant for every run;
// shipping again inserts nothing; the query commands print the same tables
// from the plant as from the station file for a station's own lots, and the
// split lot's units from both. Then what a plant meets: a station file
// edited after signing (refused, named, nothing of it stored), a station
// restored from an old backup (behind: nothing shipped, nothing lost), a
// run judged again after it was shipped (arrives as its new round, the old
// one kept).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <sstream>
#include <vector>

#include "store/archive.h"
#include "store/canonical.h"
#include "store/plant_schema.h"
#include "tests/csv_table.h"
#include "tests/test_util.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::CommandResult;
using testing::RunCommand;

const std::string kScripts = std::string(IMUQUAL_SOURCE_DIR) + "/scripts";

class PlantTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir("plant");
    const CommandResult start =
        RunCommand(kScripts + "/pg-throwaway start " + dir_->path("cluster"));
    ASSERT_EQ(start.exit_code, 0) << "the throwaway PostgreSQL cluster did not start";
    admin_url_ = start.output.substr(0, start.output.find('\n'));
    ASSERT_TRUE(admin_url_.starts_with("postgresql://")) << admin_url_;
    // Keys of station A's roles: its runs are signed, and checked at the plant.
    const std::string keys = dir_->path("keys");
    std::filesystem::create_directories(keys);
    ASSERT_EQ(RunCommand(Bin("imuqual") + " keygen --out " + keys + "/station.key").exit_code, 0);
    for (const char* role : {"acquire", "analyze", "store"}) {
      ASSERT_EQ(RunCommand(Bin("imuqual") + " keygen --role " + role + " --out " + keys + "/" +
                           role + ".key")
                    .exit_code,
                0);
    }
    ASSERT_EQ(RunCommand("cat " + keys + "/acquire.key.pub " + keys + "/analyze.key.pub " + keys +
                         "/store.key.pub > " + keys + "/station.trust")
                  .exit_code,
              0);
    keyed_ = " --key-file " + keys + "/station.key --trust " + keys + "/station.trust" +
             " --sign-key acquire=" + keys + "/acquire.key --sign-key analyze=" + keys +
             "/analyze.key --sign-key store=" + keys + "/store.key";
    trust_ = keys + "/station.trust";
    // Station A: lot P-ONLY-A (3 units) and 2 units of the split lot; station
    // B (unsigned): 2 more units of the split lot and lot P-ONLY-B.
    station_a_ = dir_->path("station-a.db");
    station_b_ = dir_->path("station-b.db");
    Soak(station_a_, "st-a", "P-ONLY-A", 3, keyed_);
    Soak(station_a_, "st-a", "P-SPLIT", 2, keyed_);
    // A copy of A as it was before its last soak: the old backup.
    std::filesystem::copy_file(station_a_, dir_->path("station-a-backup.db"));
    Soak(station_a_, "st-a", "P-ONLY-A2", 1, keyed_);
    Soak(station_b_, "st-b", "P-SPLIT", 2, "", /*first=*/2);
    Soak(station_b_, "st-b", "P-ONLY-B", 2, "");
  }
  static void TearDownTestSuite() {
    RunCommand(kScripts + "/pg-throwaway stop " + dir_->path("cluster"));
    delete dir_;
  }

  // A soak of `units` simulated VG700-like gyros, in a network namespace of
  // its own (tests/netns_run) where namespaces are available.
  // `first` > 0: the units are LOT-U<first>, ... (simulator units first+1...).
  static void Soak(const std::string& db, const std::string& station, const std::string& lot,
                   int units, const std::string& keys, int first = 0) {
    std::string which = " --sim " + std::to_string(units);
    if (first > 0) {
      which.clear();
      for (int i = first; i < first + units; ++i) {
        char serial[64];
        std::snprintf(serial, sizeof serial, "%s-U%02d", lot.c_str(), i + 1);
        which += std::string(" --unit ") + serial + "=sim:vg700,index=" + std::to_string(i);
      }
    }
    const CommandResult r = RunCommand(
        "env -u IMUQUAL_NETNS " + std::string(IMUQUAL_SOURCE_DIR) + "/tests/netns_run " +
        Bin("imuqual") + " run --quiet" + which +
        " --duration 4000 --rate 50 --plan builtin:vg700ca --lot " + lot + " --db " + db +
        " --station-id " + station + keys + " 2>&1");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }

  // A fresh database on the cluster; its URL.
  static std::string NewDatabase(const std::string& name) {
    auto admin = store::Db::Open(admin_url_, store::Db::Mode::kReadWrite);
    EXPECT_TRUE(admin.ok()) << admin.status().message();
    if (!admin.ok()) return "";
    EXPECT_TRUE((*admin)->Exec("DROP DATABASE IF EXISTS " + name).ok());
    EXPECT_TRUE((*admin)->Exec("CREATE DATABASE " + name).ok());
    std::string url = admin_url_;
    const std::string from = ":///postgres?";
    url.replace(url.find(from), from.size(), ":///" + name + "?");
    return url;
  }

  static CommandResult Sync(const std::string& station, const std::string& plant,
                            const std::string& extra = "") {
    return RunCommand(Bin("imuqual") + " sync --quiet --db " + station + " --to '" + plant + "'" +
                      extra);
  }

  static testing::TempDir* dir_;
  static std::string admin_url_, keyed_, trust_, station_a_, station_b_;
};
testing::TempDir* PlantTest::dir_ = nullptr;
std::string PlantTest::admin_url_, PlantTest::keyed_, PlantTest::trust_, PlantTest::station_a_,
    PlantTest::station_b_;

// Every row of `table` that belongs to run `run_id` (or, for lots, units and
// the chain, the rows named by `where`), each as its canonical encoding,
// sorted: equal lists are equal rows, bit for bit.
std::vector<std::string> Rows(store::Db& db, const std::string& table, const std::string& where,
                              const std::string& value) {
  auto s = db.Prepare("SELECT * FROM " + table + " WHERE " + where);
  EXPECT_TRUE(s.ok()) << table << ": " << s.status().message();
  if (!s.ok()) return {};
  s->Bind(1, value);
  std::vector<std::string> rows;
  for (;;) {
    auto row = s->Step();
    EXPECT_TRUE(row.ok()) << row.status().message();
    if (!row.ok() || !*row) break;
    rows.push_back(store::EncodeRow(
        store::RowFromStatement(*s, {"run_key", "station_archive", "archive_id", "month"})));
  }
  std::sort(rows.begin(), rows.end());
  return rows;
}

std::vector<std::string> RunIds(store::Db& db) {
  auto s = db.Prepare("SELECT run_id FROM runs ORDER BY run_id");
  std::vector<std::string> ids;
  while (s.ok() && *s->Step()) ids.push_back(s->Text(0));
  return ids;
}

// The plant holds each of the station's runs as the station does.
// reanalyze --check at the plant: each run as at the station and passing
// there (kPasses), as at the station (kAsAtStation), or not run (kSkip:
// runs without raw samples).
enum class Reanalysis { kPasses, kAsAtStation, kSkip };
void ExpectShippedWhole(const std::string& station_db, const std::string& plant_url,
                        Reanalysis reanalysis = Reanalysis::kPasses) {
  auto station = store::Archive::Open(station_db, store::Archive::Mode::kRead);
  ASSERT_TRUE(station.ok()) << station.status().message();
  auto plant = store::Archive::Open(plant_url, store::Archive::Mode::kRead);
  ASSERT_TRUE(plant.ok()) << plant.status().message();
  store::Db& s = (*station)->db();
  store::Db& p = (*plant)->db();
  const std::vector<std::string> ids = RunIds(s);
  ASSERT_FALSE(ids.empty());
  const std::string by_run = "run_key = (SELECT run_key FROM runs WHERE run_id = ?1)";
  for (const std::string& id : ids) {
    for (const char* table : {"runs", "run_axes", "raw_chunks", "gaps", "curves", "curve_points",
                              "measurements", "superseded_judgements"}) {
      const auto here = Rows(s, table, by_run, id);
      const auto there = Rows(p, table, by_run, id);
      EXPECT_EQ(here.size(), there.size()) << id << " " << table;
      EXPECT_TRUE(here == there) << id << ": " << table << " differs at the plant";
    }
    auto info = (*station)->LoadRun(id);
    ASSERT_TRUE(info.ok());
    // A lot soaked on two stations was first seen when the first saw it.
    auto seen = [&](store::Db& db) {
      auto q = db.Prepare("SELECT first_seen_utime FROM lots WHERE lot = ?1");
      EXPECT_TRUE(q.ok());
      q->Bind(1, info->lot);
      EXPECT_TRUE(*q->Step()) << info->lot;
      return q->Int(0);
    };
    EXPECT_LE(seen(p), seen(s)) << info->lot;
    EXPECT_EQ(Rows(s, "units", "serial = ?1", info->serial),
              Rows(p, "units", "serial = ?1", info->serial));
    EXPECT_EQ(Rows(s, "archive_chain", "run_id = ?1", id),
              Rows(p, "archive_chain", "run_id = ?1", id))
        << id << ": chain entries";
    // Re-analysed from the plant's raw chunks, the run gives its archived
    // result bit for bit (as at the station: a run whose result was set by
    // hand, below, differs at both).
    auto check = [&](const std::string& db) {
      return RunCommand(Bin("imuqual") + " reanalyze " + id + " --db '" + db +
                        "' --check > /dev/null 2>&1")
          .exit_code;
    };
    if (reanalysis == Reanalysis::kSkip) continue;
    // Under the sanitizers the first run of each archive only: every run
    // goes through the same code, and these re-analyses were 60 % of this
    // test's time there. The Release pass checks every run.
    if (testing::kUnderSanitizers && id != ids.front()) continue;
    const int at_station = check(station_db);
    EXPECT_EQ(check(plant_url), at_station) << id << ": reanalyze --check at the plant";
    if (reanalysis == Reanalysis::kPasses) {
      EXPECT_EQ(at_station, 0) << id << ": reanalyze --check at the station";
    }
  }
}

// A report's lines but those naming the archive and the time it was made.
std::string ReportWithoutProvenance(const std::string& path) {
  std::ifstream in(path);
  std::string out, line;
  while (std::getline(in, line)) {
    if (line.find("Generated by") == std::string::npos && line.find("Archive ") == std::string::npos) {
      out += line + "\n";
    }
  }
  EXPECT_FALSE(out.empty()) << path;
  return out;
}

std::string Imuqual(const std::string& args, const std::string& db) {
  const CommandResult r = RunCommand(Bin("imuqual") + " " + args + " --db '" + db + "' 2>&1");
  EXPECT_EQ(r.exit_code, 0) << args << " --db " << db << ": " << r.output;
  return r.output;
}

TEST_F(PlantTest, TwoStationsShipEveryRunBitForBitAndShippingAgainInsertsNothing) {
  const std::string plant = NewDatabase("plant_whole");
  const CommandResult a = Sync(station_a_, plant, " --pubkey " + trust_);
  ASSERT_EQ(a.exit_code, 0) << a.output;
  EXPECT_NE(a.output.find("6 runs shipped"), std::string::npos) << a.output;
  const CommandResult b = Sync(station_b_, plant);
  ASSERT_EQ(b.exit_code, 0) << b.output;
  EXPECT_NE(b.output.find("4 runs shipped"), std::string::npos) << b.output;
  ExpectShippedWhole(station_a_, plant);
  ExpectShippedWhole(station_b_, plant);
  for (const std::string& station : {station_a_, station_b_}) {
    const CommandResult again = Sync(station, plant);
    ASSERT_EQ(again.exit_code, 0) << again.output;
    EXPECT_NE(again.output.find("0 runs shipped (0 replaced: judged again), 0 rows inserted"),
              std::string::npos)
        << again.output;
  }

  // The same tables from the plant as from the station, for its own lots.
  for (const auto& [lot, station] : std::vector<std::pair<std::string, std::string>>{
           {"P-ONLY-A", station_a_}, {"P-ONLY-A2", station_a_}, {"P-ONLY-B", station_b_}}) {
    for (const std::string& args : {"lot " + lot, "lot " + lot + " --stats",
                                    "lot " + lot + " --format csv", "compare " + lot + " " + lot,
                                    "export --lot " + lot + " --format measurements"}) {
      EXPECT_EQ(Imuqual(args, station), Imuqual(args, plant)) << args;
    }
    auto s = store::Archive::Open(station, store::Archive::Mode::kRead);
    ASSERT_TRUE(s.ok());
    for (const std::string& id : RunIds((*s)->db())) {
      auto info = (*s)->LoadRun(id);
      ASSERT_TRUE(info.ok());
      if (info->lot != lot) continue;
      EXPECT_EQ(Imuqual("unit " + info->serial, station), Imuqual("unit " + info->serial, plant));
    }
  }
  // The split lot: its units from both stations, each as its station has it.
  const std::string split = Imuqual("lot P-SPLIT --format csv", plant);
  for (const std::string& station : {station_a_, station_b_}) {
    const std::string part = Imuqual("lot P-SPLIT --format csv", station);
    size_t start = part.find('\n') + 1;  // past the header
    while (start < part.size()) {
      const size_t end = part.find('\n', start);
      const std::string line = part.substr(start, end - start);
      if (!line.empty()) {
        EXPECT_NE(split.find(line), std::string::npos) << line;
      }
      start = end == std::string::npos ? part.size() : end + 1;
    }
  }
  // The plant proves itself: every chain as shipped, every run against its
  // signed record (A's signatures checked; B signs nothing).
  const CommandResult verified = RunCommand(Bin("imuqual") + " verify --db '" + plant +
                                            "' --pubkey " + trust_ + " --allow-unsigned 2>&1");
  EXPECT_EQ(verified.exit_code, 0) << verified.output;
  EXPECT_NE(verified.output.find("10 runs verified"), std::string::npos) << verified.output;
  const std::string lots = Imuqual("lots --format csv", plant);
  for (const char* lot : {"P-ONLY-A", "P-ONLY-A2", "P-SPLIT", "P-ONLY-B"}) {
    EXPECT_NE(lots.find(lot), std::string::npos) << lot;
  }
  // The report renders from the plant as from the station (the archive's
  // name aside).
  const std::string html_a = dir_->path("a.html"), html_p = dir_->path("p.html");
  Imuqual("report --lot P-ONLY-B -o " + html_a, station_b_);
  Imuqual("report --lot P-ONLY-B -o " + html_p, plant);
  EXPECT_EQ(ReportWithoutProvenance(html_a), ReportWithoutProvenance(html_p));
}

// A run as one text: every field LoadRun, LoadResult and LoadCurves read.
std::string RunText(const store::RunInfo& i, const std::optional<store::ResultRecord>& r,
                    const std::vector<store::CurveRecord>& curves) {
  std::ostringstream o;
  o.precision(17);
  o << i.run_id << '|' << i.serial << '|' << i.lot << '|' << i.station << '|' << i.slot << '|'
    << i.operator_name << '|' << i.source << '|' << i.software_version << '|' << i.start_utime
    << '|' << i.nominal_rate_hz << '|' << i.plan.size() << '|' << i.plan_sha256 << '|'
    << i.truth.size() << '|' << i.state << '|' << i.last_seq << '|' << i.samples_announced << '|'
    << i.first_sample << '|' << i.end_sample << '|' << i.end_utime.value_or(-1) << '|'
    << i.end_reason << '|' << i.revision << '|' << i.bus_auth << '\n';
  for (const store::AxisInfo& a : i.axes) o << a.name << ':' << static_cast<int>(a.kind) << ' ';
  o << '\n';
  if (r) {
    o << r->verdict << '|' << r->samples << '|' << r->gap_samples << '|' << r->invalid_samples
      << '|' << r->record.size() << '|' << r->result_utime << '|' << r->revision << '|'
      << r->last_seq.value_or(-1) << '|' << r->gap_batches.value_or(-1) << '\n';
    for (const std::string& s : r->reasons) o << s << ';';
    for (int64_t n : r->axis_invalid_samples) o << n << ',';
    for (const pb::Measurement& m : r->measurements) o << m.SerializeAsString().size() << m.ShortDebugString() << '\n';
  }
  for (const store::CurveRecord& c : curves) {
    o << c.axis << ' ' << static_cast<int>(c.curve.deviation) << ' ' << c.samples << ' '
      << c.valid_samples << ' ' << c.computed_utime << ' ' << c.curve.tau0_s << '\n';
    for (const allan::CurvePoint& p : c.curve.points) {
      o << p.m << ' ' << p.tau_s << ' ' << p.dev << ' ' << p.lo << ' ' << p.hi << ' ' << p.edf
        << ' ' << p.n << ' ' << p.stride << ' ' << p.alpha.value_or(99) << ' ' << p.alpha_inherited << '\n';
    }
  }
  return o.str();
}

// A lot's runs read at once (what the lot report reads) equal each run read
// on its own, on the station's file and at the plant.
TEST_F(PlantTest, ALotsRunsReadAtOnceEqualEachRunReadAlone) {
  const std::string plant = NewDatabase("plant_lot_runs");
  ASSERT_EQ(Sync(station_a_, plant).exit_code, 0);
  ASSERT_EQ(Sync(station_b_, plant).exit_code, 0);
  for (const std::string& where : {station_a_, plant}) {
    auto a = store::Archive::Open(where, store::Archive::Mode::kRead);
    ASSERT_TRUE(a.ok());
    for (const std::string lot : {"P-ONLY-A", "P-SPLIT"}) {
      auto runs = (*a)->LoadLotRuns(lot);
      ASSERT_TRUE(runs.ok()) << runs.status().message();
      ASSERT_FALSE(runs->empty()) << lot;
      for (const store::LotRunRecord& r : *runs) {
        auto info = (*a)->LoadRun(r.info.run_id);
        ASSERT_TRUE(info.ok());
        auto result = (*a)->LoadResult(r.run_key);
        ASSERT_TRUE(result.ok());
        auto curves = (*a)->LoadCurves(r.run_key);
        ASSERT_TRUE(curves.ok());
        if (r.result && *result) {
          EXPECT_TRUE(r.result->record.empty());
          (*result)->record.clear();  // not read with the lot
        }
        EXPECT_EQ(RunText(r.info, r.result, r.curves), RunText(*info, *result, *curves))
            << where << " " << r.info.run_id;
      }
      // A lot page's first view: the same runs, axes and verdicts, without
      // measurements or curves.
      auto first = (*a)->LoadLotRuns(lot, store::LotRunParts::kRuns);
      ASSERT_TRUE(first.ok()) << first.status().message();
      ASSERT_EQ(first->size(), runs->size());
      for (size_t i = 0; i < first->size(); ++i) {
        const store::LotRunRecord& f = (*first)[i];
        const store::LotRunRecord& r = (*runs)[i];
        EXPECT_EQ(f.info.run_id, r.info.run_id);
        EXPECT_EQ(f.info.axes.size(), r.info.axes.size());
        EXPECT_TRUE(f.curves.empty());
        ASSERT_EQ(f.result.has_value(), r.result.has_value());
        if (!f.result) continue;
        EXPECT_TRUE(f.result->measurements.empty());
        EXPECT_EQ(f.result->verdict, r.result->verdict);
        EXPECT_EQ(f.result->reasons, r.result->reasons);
      }
    }
  }
}

// Raw chunks at the plant live in the partition of their run's start month,
// which the sync makes when it owns raw_chunks.
TEST_F(PlantTest, RawChunksLiveInTheirRunsMonthPartition) {
  const std::string plant = NewDatabase("plant_months");
  ASSERT_EQ(Sync(station_b_, plant).exit_code, 0);
  auto p = store::Archive::Open(plant, store::Archive::Mode::kRead);
  ASSERT_TRUE(p.ok());
  auto s = (*p)->db().Prepare(
      "SELECT c.tableoid::regclass::text, to_char(to_timestamp(r.start_utime / 1e6) AT TIME ZONE "
      "'UTC', 'YYYYMM'), count(*) FROM raw_chunks c JOIN runs r USING (run_key) GROUP BY 1, 2");
  ASSERT_TRUE(s.ok()) << s.status().message();
  int groups = 0;
  while (*s->Step()) {
    ++groups;
    EXPECT_EQ(s->Text(0), "raw_chunks_" + s->Text(1)) << s->Int(2) << " chunks";
  }
  EXPECT_GE(groups, 1);
}

// The production roles of the README: the owner makes the schema, the
// stations ship as an ingest role that may insert (and replace a run's
// result rows) but owns nothing. Its chunks wait in the default partition
// when their month's partition is not made yet (said), and the plant holds
// the runs whole all the same; the read-only role reads and verifies.
TEST_F(PlantTest, AStationShipsAsTheReadmesIngestRoleAndIsReadAsItsReadRole) {
  const std::string plant = NewDatabase("plant_roles");
  // The owner makes the schema: a history without raw samples (no month).
  const std::string history = dir_->path("roles-history.db");
  ASSERT_EQ(RunCommand(Bin("imuqual-history-gen") + " --db " + history +
                       " --lots 1 --units 2 --prefix R > /dev/null")
                .exit_code,
            0);
  ASSERT_EQ(Sync(history, plant).exit_code, 0);
  {
    auto owner = store::Db::Open(plant, store::Db::Mode::kReadWrite);
    ASSERT_TRUE(owner.ok());
    const Status grants = (*owner)->Exec(R"sql(
DROP ROLE IF EXISTS imuqual_ingest; DROP ROLE IF EXISTS imuqual_read;
CREATE ROLE imuqual_ingest LOGIN;
GRANT SELECT, INSERT ON ALL TABLES IN SCHEMA public TO imuqual_ingest;
GRANT UPDATE ON runs, station_archives, station_ids, lots, units TO imuqual_ingest;
GRANT DELETE ON run_axes, gaps, curves, curve_points, measurements, superseded_judgements
  TO imuqual_ingest;
CREATE ROLE imuqual_read LOGIN;
GRANT SELECT ON ALL TABLES IN SCHEMA public TO imuqual_read;)sql");
    ASSERT_TRUE(grants.ok()) << grants.message();
  }
  auto as = [&](const std::string& role) {
    std::string url = plant;
    url.replace(url.find("user=imuqual"), 12, "user=" + role);
    return url;
  };
  const CommandResult r = RunCommand(Bin("imuqual") + " sync --quiet --db " + station_b_ +
                                     " --to '" + as("imuqual_ingest") + "' 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("went to the default partition"), std::string::npos) << r.output;
  ExpectShippedWhole(station_b_, as("imuqual_read"));
  const CommandResult verify =
      RunCommand(Bin("imuqual") + " verify --db '" + as("imuqual_read") + "' 2>&1");
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  // The ingest role can neither change nor delete evidence.
  auto ingest = store::Db::Open(as("imuqual_ingest"), store::Db::Mode::kReadWrite);
  ASSERT_TRUE(ingest.ok());
  EXPECT_FALSE((*ingest)->Exec("DELETE FROM archive_chain").ok());
  EXPECT_FALSE((*ingest)->Exec("UPDATE raw_chunks SET data = data").ok());
  EXPECT_FALSE((*ingest)->Exec("DELETE FROM raw_chunks").ok());
}

TEST_F(PlantTest, AStationFileEditedAfterSigningIsRefusedAndNamed) {
  const std::string plant = NewDatabase("plant_tampered");
  const std::string edited = dir_->path("station-b-edited.db");
  std::filesystem::copy_file(station_b_, edited, std::filesystem::copy_options::overwrite_existing);
  // The third run of B's chain reads 10 % better than measured (its results
  // checksum recomputed, as an editor with the tools would).
  auto a = store::Archive::Open(edited, store::Archive::Mode::kWrite);
  ASSERT_TRUE(a.ok());
  auto third = (*a)->db().Prepare("SELECT run_id FROM archive_chain WHERE entry = 3");
  ASSERT_TRUE(third.ok() && *third->Step());
  const std::string victim = third->Text(0);
  third->Reset();
  ASSERT_TRUE((*a)->db()
                  .Exec("UPDATE measurements SET value = value * 0.9 WHERE name = "
                        "'bias_instability' AND run_key = (SELECT run_key FROM runs WHERE run_id "
                        "= '" + victim + "')")
                  .ok());
  a->reset();
  const CommandResult r = Sync(edited, plant, " --batch 1");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  auto plant_archive = store::Archive::Open(plant, store::Archive::Mode::kRead);
  ASSERT_TRUE(plant_archive.ok());
  auto key = (*plant_archive)->FindRunKey(victim);
  ASSERT_TRUE(key.ok());
  EXPECT_FALSE(key->has_value()) << "the edited run was stored at the plant";
  // The two entries before it are shipped; nothing after it.
  auto n = (*plant_archive)->db().QueryInt("SELECT shipped_entries FROM station_archives");
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 2);
  // An edit at the plant itself is found by verify, naming the run.
  {
    auto w = store::Db::Open(plant, store::Db::Mode::kReadWrite);
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE((*w)->Exec("UPDATE measurements SET value = value * 0.9 WHERE name = "
                           "'bias_instability' AND run_key = (SELECT min(run_key) FROM runs)")
                    .ok());
  }
  const CommandResult verify =
      RunCommand(Bin("imuqual") + " verify --db '" + plant + "' 2>/dev/null");
  EXPECT_EQ(verify.exit_code, 1) << verify.output;
  EXPECT_NE(verify.output.find("do not match its signed record (measurements)"), std::string::npos)
      << verify.output;
  const CommandResult again = RunCommand(Bin("imuqual") + " sync --db " + edited + " --to '" +
                                         plant + "' 2>&1 >/dev/null");
  EXPECT_EQ(again.exit_code, 3);
  EXPECT_NE(again.output.find("run " + victim), std::string::npos) << again.output;
  EXPECT_NE(again.output.find("measurements"), std::string::npos) << again.output;
}

TEST_F(PlantTest, AStationRestoredFromAnOldBackupShipsNothingAndLosesNothing) {
  const std::string plant = NewDatabase("plant_backup");
  ASSERT_EQ(Sync(station_a_, plant).exit_code, 0);
  const CommandResult r = Sync(dir_->path("station-a-backup.db"), plant);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("behind the plant"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0 rows inserted"), std::string::npos) << r.output;
  ExpectShippedWhole(station_a_, plant);
}

// Two station archives claiming one station id (a second host set up with
// the first one's id, or a rebuilt station): the first archive to ship a
// run of the id holds it; the second is refused, named, nothing of it
// stored, until a sync names it that station's new archive. Then the old
// archive's further runs of the id are refused.
TEST_F(PlantTest, TwoStationsClaimingOneStationIdAreRefusedUntilOneIsNamedItsNewArchive) {
  const std::string plant = NewDatabase("plant_claims");
  const std::string rebuilt = dir_->path("station-a-rebuilt.db");
  Soak(rebuilt, "st-a", "P-CLAIM", 1, keyed_);
  // A, as it was before its last soak, ships first: st-a is its.
  ASSERT_EQ(Sync(dir_->path("station-a-backup.db"), plant).exit_code, 0);
  const CommandResult second =
      RunCommand(Bin("imuqual") + " sync --quiet --db " + rebuilt + " --to '" + plant + "' 2>&1");
  EXPECT_EQ(second.exit_code, 3) << second.output;
  EXPECT_NE(second.output.find("station id st-a is held at the plant by another station archive"),
            std::string::npos)
      << second.output;
  EXPECT_NE(second.output.find("--new-archive-of st-a"), std::string::npos) << second.output;
  {
    auto p = store::Archive::Open(plant, store::Archive::Mode::kRead);
    ASSERT_TRUE(p.ok());
    auto n = (*p)->db().QueryInt("SELECT count(*) FROM runs WHERE lot = 'P-CLAIM'");
    ASSERT_TRUE(n.ok());
    EXPECT_EQ(*n, 0) << "a run of the refused archive was stored";
  }
  // Named st-a's new archive: it ships, and the move is recorded.
  const CommandResult moved = RunCommand(Bin("imuqual") + " sync --quiet --db " + rebuilt +
                                         " --to '" + plant + "' --new-archive-of st-a 2>&1");
  EXPECT_EQ(moved.exit_code, 0) << moved.output;
  EXPECT_NE(moved.output.find("station id st-a moved to this archive"), std::string::npos)
      << moved.output;
  ExpectShippedWhole(rebuilt, plant);
  {
    auto p = store::Archive::Open(plant, store::Archive::Mode::kRead);
    ASSERT_TRUE(p.ok());
    auto s = (*p)->db().Prepare(
        "SELECT previous_archive IS NOT NULL, claimed_by FROM station_ids WHERE station = 'st-a'");
    ASSERT_TRUE(s.ok());
    ASSERT_TRUE(*s->Step());
    EXPECT_EQ(s->Int(0), 1);
    EXPECT_NE(s->Text(1).find("imuqual sync"), std::string::npos) << s->Text(1);
  }
  // The old archive (now with one more run of st-a) is refused from then on;
  // what it shipped before stays.
  const CommandResult old =
      RunCommand(Bin("imuqual") + " sync --quiet --db " + station_a_ + " --to '" + plant + "' 2>&1");
  EXPECT_EQ(old.exit_code, 3) << old.output;
  EXPECT_NE(old.output.find("station id st-a moved from this station archive"), std::string::npos)
      << old.output;
  ExpectShippedWhole(dir_->path("station-a-backup.db"), plant, Reanalysis::kSkip);
}

// A plant archive of schema 1 (before station ids were held) is upgraded by
// the next sync: each station id held by the archive of its latest run.
TEST_F(PlantTest, APlantOfSchemaOneIsUpgradedByTheNextSync) {
  const std::string plant = NewDatabase("plant_upgrade");
  ASSERT_EQ(Sync(station_b_, plant).exit_code, 0);
  {
    auto w = store::Db::Open(plant, store::Db::Mode::kReadWrite);
    ASSERT_TRUE(w.ok());
    // As schema 1 was: no station_ids, no covering indexes.
    ASSERT_TRUE((*w)->Exec("DROP TABLE station_ids; DROP INDEX measurements_values; DROP INDEX "
                           "runs_final; CREATE INDEX measurements_by_name ON measurements(name, "
                           "axis); UPDATE imuqual_plant SET version = 1")
                    .ok());
  }
  const CommandResult old_reader =
      RunCommand(Bin("imuqual") + " lots --db '" + plant + "' 2>&1");
  EXPECT_NE(old_reader.exit_code, 0);
  EXPECT_NE(old_reader.output.find("holds plant schema 1"), std::string::npos) << old_reader.output;
  const CommandResult r = Sync(station_a_, plant);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  auto p = store::Archive::Open(plant, store::Archive::Mode::kRead);
  ASSERT_TRUE(p.ok()) << p.status().message();
  auto v = (*p)->db().QueryInt("SELECT version FROM imuqual_plant");
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(*v, store::PlantSchemaVersion());
  auto held = (*p)->db().QueryInt(
      "SELECT count(*) FROM station_ids i JOIN station_archives a USING (archive_id) WHERE "
      "i.station IN ('st-a', 'st-b')");
  ASSERT_TRUE(held.ok());
  EXPECT_EQ(*held, 2);
  auto indexes = (*p)->db().QueryInt(
      "SELECT count(*) FROM pg_catalog.pg_indexes WHERE indexname IN ('measurements_values', "
      "'runs_final')");
  ASSERT_TRUE(indexes.ok());
  EXPECT_EQ(*indexes, 2);
  // B's id is held by B's archive: another archive claiming it is refused.
  const std::string other = dir_->path("station-b-other.db");
  Soak(other, "st-b", "P-OTHER", 1, "");
  const CommandResult claim = Sync(other, plant);
  EXPECT_EQ(claim.exit_code, 3) << claim.output;
}

TEST_F(PlantTest, ARunJudgedAgainAfterShippingArrivesAsItsNewRoundWithTheOldKept) {
  const std::string plant = NewDatabase("plant_rejudged");
  const std::string station = dir_->path("station-b-rejudged.db");
  std::filesystem::copy_file(station_b_, station,
                             std::filesystem::copy_options::overwrite_existing);
  ASSERT_EQ(Sync(station, plant).exit_code, 0);
  // The station judges one run again (reanalyze --rejudge would, after a
  // plan correction): its round is superseded, re-judged and finalised.
  std::string id;
  {
    auto a = store::Archive::Open(station, store::Archive::Mode::kWrite);
    ASSERT_TRUE(a.ok());
    id = RunIds((*a)->db()).front();
    auto key = (*a)->FindRunKey(id);
    ASSERT_TRUE(key.ok() && key->has_value());
    auto result = (*a)->LoadResult(**key);
    ASSERT_TRUE(result.ok() && result->has_value());
    auto curves = (*a)->LoadCurves(**key);
    ASSERT_TRUE(curves.ok());
    ASSERT_TRUE((*a)->Begin().ok());
    ASSERT_TRUE((*a)->SupersedeJudgement(**key, 2'000'000'000'000'000, "plan corrected").ok());
    for (const store::CurveRecord& c : *curves) ASSERT_TRUE((*a)->PutCurve(**key, c).ok());
    store::ResultRecord again = **result;
    again.reasons.push_back("judged again: plan corrected");
    again.revision = 1;
    ASSERT_TRUE((*a)->PutResult(**key, again).ok());
    ASSERT_TRUE((*a)->MarkFinalized(**key, 2'000'000'000'000'001).ok());
    ASSERT_TRUE((*a)->Commit().ok());
  }
  const CommandResult r = Sync(station, plant);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 runs shipped (1 replaced"), std::string::npos) << r.output;
  ExpectShippedWhole(station, plant, Reanalysis::kAsAtStation);
  auto p = store::Archive::Open(plant, store::Archive::Mode::kRead);
  ASSERT_TRUE(p.ok());
  auto rounds = (*p)->db().QueryInt(
      "SELECT count(*) FROM superseded_judgements WHERE run_key = (SELECT run_key FROM runs "
      "WHERE run_id = '" + id + "')");
  ASSERT_TRUE(rounds.ok());
  EXPECT_EQ(*rounds, 1);
  auto entries = (*p)->db().QueryInt("SELECT count(*) FROM archive_chain WHERE run_id = '" + id +
                                     "'");
  ASSERT_TRUE(entries.ok());
  EXPECT_EQ(*entries, 3);  // finalised, reopened, finalised again
}

TEST_F(PlantTest, TheStoreShipsEachRunToThePlantAsItIsFinalised) {
  const std::string plant = NewDatabase("plant_forward");
  const std::string station = dir_->path("station-c.db");
  // The store ships as the soak goes (--sync-to), with no sync by hand.
  Soak(station, "st-c", "P-FORWARD", 3, " --sync-to '" + plant + "'");
  ExpectShippedWhole(station, plant);
  // A second soak with the plant away: the station is unaffected; the next
  // soak's store catches the plant up.
  const std::string cluster = dir_->path("cluster");
  ASSERT_EQ(RunCommand(kScripts + "/pg-throwaway stop " + cluster).exit_code, 0);
  Soak(station, "st-c", "P-FORWARD-2", 2, " --sync-to '" + plant + "'");
  ASSERT_EQ(RunCommand(kScripts + "/pg-throwaway start-again " + cluster).exit_code, 0);
  Soak(station, "st-c", "P-FORWARD-3", 1, " --sync-to '" + plant + "'");
  ExpectShippedWhole(station, plant);
  const CommandResult again = Sync(station, plant);
  EXPECT_NE(again.output.find("0 rows inserted"), std::string::npos) << again.output;
}

TEST_F(PlantTest, StationsShippedToThePlantAreComparedAndTheOneReadingHighIsNamed) {
  // 8 golden units soaked 3 times on each of 3 stations, each station its
  // own archive; station-3 reads every unit's noise 10 % high. Shipped to
  // the plant, compared there.
  const std::string plant = NewDatabase("plant_msa");
  for (int k = 1; k <= 3; ++k) {
    const std::string station = dir_->path("golden-" + std::to_string(k) + ".db");
    ASSERT_EQ(RunCommand(Bin("imuqual-history-gen") + " --db " + station +
                         " --lots 0 --units 8 --golden-stations 3 --golden-trials 3 --prefix M "
                         "--station-gain station-3=1.1 --only-station station-" +
                         std::to_string(k) + " > /dev/null")
                  .exit_code,
              0);
    ASSERT_EQ(Sync(station, plant).exit_code, 0);
  }
  const CommandResult msa = RunCommand(Bin("imuqual") + " msa --db '" + plant +
                                       "' --lot M-GOLDEN --measurement bias_instability "
                                       "--format csv");
  EXPECT_EQ(msa.exit_code, 3) << "a station that differs is an exit 3: " << msa.output;
  // The offsets table follows the studies after a blank line.
  const size_t blank = msa.output.find("\n\n");
  ASSERT_NE(blank, std::string::npos) << msa.output;
  const testing::Csv studies = testing::ParseCsv(msa.output.substr(0, blank + 1));
  const testing::Csv offsets = testing::ParseCsv(msa.output.substr(blank + 2));
  EXPECT_EQ(studies.rows.size(), 6u);  // gx gy gz ax ay az
  for (const auto& r : studies.rows) {
    EXPECT_EQ(r[studies.Col("stations")], "3");
    EXPECT_EQ(r[studies.Col("trials")], "3");
    EXPECT_EQ(r[studies.Col("units")], "8");
  }
  // Station-3 is 1.1 / mean(1, 1, 1.1) - 1 = +6.5 % above the fleet, the
  // others -3.2 %: named on most axes, found near its size.
  const double truth = 1.1 / (3.1 / 3) - 1;
  int named = 0, others_named = 0, axes = 0;
  double sum = 0;
  for (const auto& r : offsets.rows) {
    const bool differs = r[offsets.Col("differs")] == "true";
    if (r[offsets.Col("station")] == "station-3") {
      ++axes;
      named += differs;
      sum += std::stod(r[offsets.Col("offset_percent")]) / 100;
    } else {
      others_named += differs;
    }
  }
  ASSERT_EQ(axes, 6);
  EXPECT_GE(named, 5) << msa.output;
  EXPECT_NEAR(sum / axes, truth, 0.025) << msa.output;
  EXPECT_LE(others_named, 6) << msa.output;

  // The plant's pages say the same: the station out of agreement named on
  // the MSA page, yields per station, the study as JSON.
  const std::string log = dir_->path("serve-msa.log");
  RunCommand(Bin("imuqual") + " serve --db '" + plant + "' --listen 127.0.0.1:0 > " + log +
             " 2>&1 & echo $! > " + dir_->path("serve-msa.pid"));
  std::string base;
  for (int i = 0; i < 500 && base.empty(); ++i) {
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line)) {
      const size_t at = line.find(" at http://");
      if (line.starts_with("serving ") && at != std::string::npos) {
        base = line.substr(at + 4, line.find(' ', at + 4) - at - 4);
      }
    }
    if (base.empty()) ::usleep(10'000);
  }
  ASSERT_FALSE(base.empty()) << "imuqual serve did not start on the plant";
  auto get = [&](const std::string& path) {
    return RunCommand("curl -s '" + base + path.substr(1) + "'").output;
  };
  const std::string page = get("/msa?lot=M-GOLDEN&measurement=bias_instability&axis=gx");
  EXPECT_NE(page.find("Out of agreement"), std::string::npos) << page;
  EXPECT_NE(page.find("station-3 (gx bias_instability)"), std::string::npos) << page;
  const std::string json = get("/api/msa?lot=M-GOLDEN&measurement=bias_instability&axis=gx");
  EXPECT_NE(json.find("\"station\": \"station-3\""), std::string::npos) << json;
  // Yields count each unit once, where it was first tested: the golden
  // units all started on station-1.
  const std::string yields = get("/api/yields?by=station");
  EXPECT_NE(yields.find("\"group\": \"station-1\", \"units\": 8, \"runs\": 72"),
            std::string::npos)
      << yields;
  RunCommand("kill $(cat " + dir_->path("serve-msa.pid") + ")");
}

TEST_F(PlantTest, AControlChartAtThePlantFindsADriftingProcessAsTheStationDoes) {
  // 12 lots of 30 units whose noise worsens 5 % a lot: against the first 4
  // lots, the later ones are out of control.
  const std::string plant = NewDatabase("plant_chart");
  const std::string station = dir_->path("drifting.db");
  ASSERT_EQ(RunCommand(Bin("imuqual-history-gen") + " --db " + station +
                       " --lots 12 --units 30 --drift 0.05 --prefix D > /dev/null")
                .exit_code,
            0);
  ASSERT_EQ(Sync(station, plant).exit_code, 0);
  const std::string args =
      " chart --measurement angle_random_walk --axis gx --by lot --baseline 4 --format csv --db ";
  const CommandResult here = RunCommand(Bin("imuqual") + args + station);
  const CommandResult there = RunCommand(Bin("imuqual") + args + "'" + plant + "'");
  EXPECT_EQ(here.exit_code, 3) << here.output;
  EXPECT_EQ(there.exit_code, 3) << there.output;
  EXPECT_EQ(here.output, there.output);
  const testing::Csv chart = testing::ParseCsv(there.output);
  ASSERT_EQ(chart.rows.size(), 12u);
  int flagged_late = 0;
  for (size_t i = 0; i < chart.rows.size(); ++i) {
    const bool flagged = !chart.rows[i][chart.Col("rules")].empty();
    if (i >= 8) flagged_late += flagged;
  }
  EXPECT_GE(flagged_late, 3) << there.output;  // lots 9-12: 40-55 % worse than the baseline's
}

// Lines in a file (0 if it is not there yet).
int LinesIn(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) ++n;
  return n;
}

// Waits (bounded) for `path` to hold `lines` lines.
bool WaitForLines(const std::string& path, int lines) {
  for (int i = 0; i < 3000 && LinesIn(path) < lines; ++i) ::usleep(10'000);
  return LinesIn(path) >= lines;
}

TEST_F(PlantTest, ThePlantRestartedOrGoneAndTheSyncKilledMidwayLoseAndDuplicateNothing) {
  const std::string plant = NewDatabase("plant_faults");
  const std::string station = dir_->path("history.db");
  const std::string cluster = dir_->path("cluster");
  ASSERT_EQ(RunCommand(Bin("imuqual-history-gen") + " --db " + station +
                       " --lots 2 --units 60 --prefix F > /dev/null")
                .exit_code,
            0);
  const std::string sync = Bin("imuqual") + " sync --batch 1 --db " + station + " --to '" + plant +
                           "'";
  const std::string progress = dir_->path("progress.txt"), rc = dir_->path("rc.txt");
  auto start_sync = [&] {
    std::filesystem::remove(progress);
    std::filesystem::remove(rc);
    // In the background, holding none of RunCommand's pipe.
    RunCommand("(" + sync + " > /dev/null 2> " + progress + "; echo $? > " + rc +
               ") > /dev/null 2>&1 &");
  };
  auto wait_exit = [&] {
    for (int i = 0; i < 3000 && LinesIn(rc) == 0; ++i) ::usleep(10'000);
    std::ifstream in(rc);
    int code = -1;
    in >> code;
    return code;
  };

  // PostgreSQL restarted (a fast shutdown ends every session) mid-sync.
  start_sync();
  ASSERT_TRUE(WaitForLines(progress, 5));
  ASSERT_EQ(RunCommand(kScripts + "/pg-throwaway stop " + cluster).exit_code, 0);
  EXPECT_EQ(wait_exit(), 1) << "the sync went on without its plant";
  ASSERT_EQ(RunCommand(kScripts + "/pg-throwaway start-again " + cluster).exit_code, 0);
  // The sync itself killed outright mid-batch.
  start_sync();
  ASSERT_TRUE(WaitForLines(progress, 5));
  // [s]: the pattern does not match the shell that runs pkill or pgrep.
  const std::string pattern = "'[s]ync --batch 1 --db " + station + "'";
  RunCommand("pkill -9 -f " + pattern);  // the sync and the shell around it
  for (int i = 0; i < 3000 && RunCommand("pgrep -f " + pattern + " > /dev/null").exit_code == 0;
       ++i) {
    ::usleep(10'000);
  }
  {
    // The kill landed mid-way: some entries shipped, not all.
    auto p = store::Archive::Open(plant, store::Archive::Mode::kRead);
    ASSERT_TRUE(p.ok());
    auto shipped = (*p)->db().QueryInt("SELECT shipped_entries FROM station_archives");
    ASSERT_TRUE(shipped.ok());
    EXPECT_GT(*shipped, 0);
    EXPECT_LT(*shipped, 120) << "the sync ended before it was killed: the test tested nothing";
  }
  // The plant gone: said at once, nothing changes.
  ASSERT_EQ(RunCommand(kScripts + "/pg-throwaway stop " + cluster).exit_code, 0);
  const CommandResult gone = RunCommand(sync + " 2>&1");
  EXPECT_EQ(gone.exit_code, 1) << gone.output;
  EXPECT_NE(gone.output.find("cannot connect to the plant archive"), std::string::npos)
      << gone.output;
  ASSERT_EQ(RunCommand(kScripts + "/pg-throwaway start-again " + cluster).exit_code, 0);
  // Back: the sync resumes where the plant's cursor is, and ends whole.
  const CommandResult resumed = RunCommand(sync + " 2>/dev/null");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_EQ(resumed.output.find("(were 0)"), std::string::npos) << resumed.output;
  ExpectShippedWhole(station, plant, Reanalysis::kSkip);  // generated runs: no raw samples
  const CommandResult verified = RunCommand(Bin("imuqual") + " verify --db '" + plant + "' 2>&1");
  EXPECT_EQ(verified.exit_code, 0) << verified.output;
  EXPECT_NE(verified.output.find("120 runs verified"), std::string::npos) << verified.output;
  const CommandResult again = RunCommand(sync + " 2>/dev/null");
  EXPECT_NE(again.output.find("0 rows inserted"), std::string::npos) << again.output;
}

}  // namespace
}  // namespace imuqual
