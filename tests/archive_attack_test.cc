// End to end, the tamper-evident archive: a short simulated lot soaked
// through a station whose store signs with a key kept outside the archive
// (one unit planted to FAIL), then, each on its own copy of the archive,
// every edit an attacker made unnoticed on the builds before schema 7:
// `imuqual verify --pubkey` names each one, and an unedited copy verifies
// clean and re-analyses bit for bit. Archives without signatures (made
// without a key, or of schema 6) report their runs unsigned.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "common/text_util.h"
#include "imuqual/plan.pb.h"
#include "store/archive.h"
#include "store/checksums.h"
#include "store/sqlite.h"
#include "tests/station_harness.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::CommandResult;
using testing::RunCommand;
using testing::StationHarness;
using testing::TempDir;

constexpr double kRunTimeoutS = 240;  // bound on any wait for a soak's runs

// clang-format off
constexpr char kPlan[] = R"pb(
name: "attack-itest"
axes { name: "x" kind: GYRO }
axes { name: "y" kind: GYRO }
axes { name: "z" kind: GYRO }
nominal_rate_hz: 100
min_duration_s: 300
warmup_s: 30
grid { kind: OCTAVE }
limits { measurement: "bias_instability" axis_kind: GYRO high: 20 marginal_high: 16 unit: "deg/h" }
limits { measurement: "angle_random_walk" axis_kind: GYRO high: 0.6 marginal_high: 0.5 unit: "deg/sqrt(h)" }
limits { measurement: "gap_fraction" high: 0.001 unit: "1" }
)pb";
// clang-format on

// The signed soak, made once for every test: two rounds on one station,
// so that the planted FAIL run is never the chain's newest entry.
struct Soak {
  std::unique_ptr<StationHarness> station;
  std::string db, pubkey;
  std::string bad_run;            // the planted failure
  std::vector<std::string> runs;  // every run id
  std::string newest_run;         // the chain's last entry
  std::string head;               // `verify --head` of the unedited archive
  std::string plan_bytes;         // the runs' plan, as archived
  bool ok = false;
};

int64_t QueryInt(const std::string& db, const std::string& sql) {
  auto d = store::Db::Open(db, store::Db::Mode::kReadOnly);
  if (!d.ok()) return -1;
  auto v = (*d)->QueryInt(sql);
  return v.ok() ? *v : -1;
}

std::string QueryText(const std::string& db, const std::string& sql) {
  auto d = store::Db::Open(db, store::Db::Mode::kReadOnly);
  if (!d.ok()) return "";
  auto s = (*d)->Prepare(sql);
  if (!s.ok()) return "";
  auto row = s->Step();
  return row.ok() && *row ? s->Text(0) : "";
}

void MakeSoak(Soak* soak) {
  soak->station = std::make_unique<StationHarness>("archive_attack");
  StationHarness& h = *soak->station;
  const std::string key = h.path("store.key");
  const CommandResult keygen =
      RunCommand(Bin("imuqual") + " keygen --role store --out " + key + " 2>&1");
  ASSERT_EQ(keygen.exit_code, 0) << keygen.output;
  soak->pubkey = key + ".pub";
  const std::string plan = h.path("plan.textproto");
  std::ofstream(plan) << kPlan;
  Subprocess store = h.StartStore({"--sign-key", key});
  Subprocess analyze = h.StartAnalyze();
  auto acquire = [&](const std::string& prefix, const std::vector<std::string>& units) {
    std::vector<std::string> args = {
        "--lot",     "ATT", "--run-prefix", prefix, "--plan",     plan,  "--await", "store,analyze",
        "--station", "st1", "--operator",   "ann",  "--duration", "330", "--rate",  "100"};
    for (const std::string& u : units) args.insert(args.end(), {"--unit", u});
    return h.Start("imuqual-acquire", args);
  };
  // Lot seed 2: units 1-3 are typical, unit 7 the planted failure (its bias
  // instability four times a typical unit's: lot_profile.h).
  Subprocess first =
      acquire("A1", {"GOOD1=sim:vg700,index=1,seed=2", "BAD=sim:vg700,index=7,seed=2"});
  ASSERT_TRUE(h.WaitRunsDone(2, kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(first.Wait(60).value_or(-1), 0) << h.Logs();
  Subprocess second =
      acquire("A2", {"GOOD2=sim:vg700,index=2,seed=2", "GOOD3=sim:vg700,index=3,seed=2"});
  ASSERT_TRUE(h.WaitRunsDone(4, kRunTimeoutS)) << h.Logs();
  EXPECT_EQ(second.Wait(60).value_or(-1), 0) << h.Logs();
  EXPECT_EQ(analyze.Stop(15), 0);
  EXPECT_EQ(store.Stop(15), 0);
  soak->db = h.db();
  soak->bad_run = "A1-BAD";
  ASSERT_EQ(QueryText(soak->db, "SELECT verdict FROM runs WHERE run_id = 'A1-BAD'"), "FAIL")
      << "the planted unit did not fail; " << h.Logs();
  auto a = store::Archive::Open(soak->db, store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  auto ids = (*a)->db().Prepare("SELECT run_id FROM runs ORDER BY run_id");
  while (*ids->Step()) soak->runs.push_back(ids->Text(0));
  ASSERT_EQ(soak->runs.size(), 4u);
  soak->newest_run =
      QueryText(soak->db, "SELECT run_id FROM archive_chain ORDER BY entry DESC LIMIT 1");
  ASSERT_TRUE(soak->newest_run.rfind("A2-", 0) == 0) << soak->newest_run;
  auto plan_row = (*a)->db().Prepare("SELECT plan FROM runs WHERE run_id = 'A1-BAD'");
  ASSERT_TRUE(*plan_row->Step());
  const std::vector<uint8_t> plan_blob = plan_row->Blob(0);
  soak->plan_bytes.assign(plan_blob.begin(), plan_blob.end());
  const CommandResult head = RunCommand(Bin("imuqual") + " verify --db " + soak->db + " --head");
  ASSERT_EQ(head.exit_code, 0) << head.output;
  soak->head = head.output.substr(0, head.output.find('\n'));
  EXPECT_EQ(soak->head.rfind("4:", 0), 0u) << soak->head;
  soak->ok = true;
}

const Soak& SignedSoak() {
  static Soak soak;
  static const bool made = (MakeSoak(&soak), true);
  (void)made;
  return soak;
}

std::string HexString(const std::string& bytes) {
  static const char kDigits[] = "0123456789abcdef";
  std::string hex;
  for (unsigned char c : bytes) {
    hex += kDigits[c >> 4];
    hex += kDigits[c & 15];
  }
  return hex;
}

class ArchiveAttackTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(SignedSoak().ok) << "the signed soak failed";
    // A copy of the archive for this test's edit; VACUUM INTO writes it
    // afresh (other rowids, other pages: the records depend on neither).
    copy_ = dir_.path("copy.db");
    auto d = store::Db::Open(SignedSoak().db, store::Db::Mode::kReadOnly);
    ASSERT_TRUE(d.ok());
    ASSERT_TRUE((*d)->Exec("VACUUM INTO '" + copy_ + "'").ok());
  }

  // An attacker's SQL on the copy, with what stops honest tools set aside.
  // The edit an attacker with write access makes: the chain's guard
  // triggers dropped for it and put back as they were, so that the schema
  // check has nothing to say and what is found is found in the records.
  void Edit(const std::string& sql) {
    std::string guards;
    {
      auto r = store::Db::Open(copy_, store::Db::Mode::kReadOnly);
      ASSERT_TRUE(r.ok());
      auto stmt = (*r)->Prepare(
          "SELECT sql FROM sqlite_master WHERE type = 'trigger' AND name LIKE 'archive_chain_%'");
      ASSERT_TRUE(stmt.ok());
      for (auto row = stmt->Step(); row.ok() && *row; row = stmt->Step()) {
        guards += stmt->Text(0) + ";\n";
      }
    }
    auto d = store::Db::Open(copy_, store::Db::Mode::kReadWrite);
    ASSERT_TRUE(d.ok());
    ASSERT_TRUE(
        (*d)->Exec("PRAGMA foreign_keys = OFF; DROP TRIGGER IF EXISTS archive_chain_no_update; "
                   "DROP TRIGGER IF EXISTS archive_chain_no_delete; " +
                   sql + "; " + guards)
            .ok())
        << sql;
  }

  // Every row of a run, in every table, and its chain entries.
  void DeleteRun(const std::string& run_id) {
    std::string sql;
    for (const char* table : {"measurements", "curve_points", "curves", "raw_chunks", "gaps",
                              "run_axes", "superseded_judgements"}) {
      sql += std::string("DELETE FROM ") + table +
             " WHERE run_key = (SELECT run_key FROM runs WHERE run_id = '" + run_id + "'); ";
    }
    sql += "DELETE FROM runs WHERE run_id = '" + run_id +
           "'; DELETE FROM archive_chain WHERE "
           "run_id = '" +
           run_id + "';";
    Edit(sql);
  }

  // verify --pubkey on the copy; what it found goes to the test's log too.
  CommandResult Verify(const std::string& extra = "") {
    CommandResult r = RunCommand(Bin("imuqual") + " verify --db " + copy_ + " --pubkey " +
                                 SignedSoak().pubkey + " " + extra);
    std::printf("verify (exit %d) found:\n%s", r.exit_code, r.output.c_str());
    return r;
  }

  std::string Key(const std::string& run_id) {
    return std::to_string(
        QueryInt(copy_, "SELECT run_key FROM runs WHERE run_id = '" + run_id + "'"));
  }

  TempDir dir_{"archive_attack_copy"};
  std::string copy_;
};

TEST_F(ArchiveAttackTest, AnUneditedCopyVerifiesCleanAndEveryRunReanalysesBitForBit) {
  const CommandResult v =
      RunCommand(Bin("imuqual") + " verify --db " + copy_ + " --pubkey " + SignedSoak().pubkey +
                 " --expect-head " + SignedSoak().head + " 2>&1");
  EXPECT_EQ(v.exit_code, 0) << v.output;
  EXPECT_NE(v.output.find("signed and verified: 4 runs"), std::string::npos) << v.output;
  for (const std::string& id : SignedSoak().runs) {
    const CommandResult c = RunCommand(Bin("imuqual") + " reanalyze " + id + " --db " + copy_ +
                                       " --check 2>&1 >/dev/null");
    EXPECT_EQ(c.exit_code, 0) << id << ": " << c.output;
  }
  // Without --pubkey: checked but for the signatures, and it says so.
  const CommandResult plain = RunCommand(Bin("imuqual") + " verify --db " + copy_ + " 2>&1");
  EXPECT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_NE(plain.output.find("signatures not checked (no --pubkey)"), std::string::npos)
      << plain.output;
  // Another store's key: every run is signed by an unknown key.
  const std::string other = dir_.path("other.key");
  ASSERT_EQ(RunCommand(Bin("imuqual") + " keygen --role store --out " + other + " 2>&1").exit_code,
            0);
  const CommandResult wrong =
      RunCommand(Bin("imuqual") + " verify --db " + copy_ + " --pubkey " + other + ".pub");
  EXPECT_EQ(wrong.exit_code, 1);
  EXPECT_NE(wrong.output.find("run " + SignedSoak().bad_run + ": signed by an unknown key"),
            std::string::npos)
      << wrong.output;
}

// A view redefined (every lot answer changes without a row touched) and a
// run slipped in unfinalised with a PASS (the views would count it): named,
// never verified.
TEST_F(ArchiveAttackTest, AViewRedefinedIsNamed) {
  Edit("DROP VIEW run_archive; CREATE VIEW run_archive AS SELECT run_id, 'complete' AS state FROM runs");
  const CommandResult v = Verify("2>&1");
  EXPECT_EQ(v.exit_code, 1);
  EXPECT_NE(v.output.find("schema: view run_archive differs from this version's definition"),
            std::string::npos)
      << v.output;
}

TEST_F(ArchiveAttackTest, ARunSlippedInWithAVerdictIsNotVerified) {
  const std::string bad = SignedSoak().bad_run;
  Edit("INSERT INTO runs(run_id, serial, lot, station, slot, operator, source, software_version, "
       "start_utime, state, nominal_rate_hz, last_seq, samples_announced, plan, plan_sha256, "
       "first_sample, end_sample, end_reason, verdict, reasons) SELECT 'A9-BAD', serial, lot, "
       "station, slot, operator, source, software_version, start_utime + 1000000, 'complete', "
       "nominal_rate_hz, last_seq, samples_announced, plan, plan_sha256, first_sample, end_sample, "
       "'', 'PASS', '' FROM runs WHERE run_id = '" + bad + "'");
  const CommandResult v = Verify("2>&1");
  EXPECT_EQ(v.exit_code, 3) << v.output;
  EXPECT_NE(v.output.find("open runs that carry a verdict (not finalised: not evidence yet"),
            std::string::npos)
      << v.output;
  EXPECT_NE(v.output.find("A9-BAD"), std::string::npos) << v.output;
}

TEST_F(ArchiveAttackTest, AVerdictEditedWithItsChecksumRecomputedIsNamed) {
  const std::string bad = SignedSoak().bad_run;
  // GIVEN the FAIL turned into a PASS, its failing measurements with it,
  // and the results' CRC recomputed exactly as store/checksums does
  Edit("UPDATE runs SET verdict = 'PASS', reasons = '' WHERE run_id = '" + bad +
       "'; "
       "UPDATE measurements SET outcome = 'PASS' WHERE outcome = 'FAIL' AND run_key = " +
       Key(bad));
  {
    auto d = store::Db::Open(copy_, store::Db::Mode::kReadWrite);
    ASSERT_TRUE(d.ok());
    ASSERT_TRUE(store::SealResults(**d, std::stoll(Key(bad))).ok());
    // (no checksum can tell: what passed verify before schema 7)
    auto damage = store::CheckChecksums(**d, -1, [](const std::string&) {});
    ASSERT_TRUE(damage.ok());
    EXPECT_EQ(*damage, 0);
  }
  // THEN verify names the run and what changed
  const CommandResult v = Verify();
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_NE(
      v.output.find("run " + bad + ": verdict changed since signed (signed 'FAIL', now 'PASS')"),
      std::string::npos)
      << v.output;
  EXPECT_NE(v.output.find("run " + bad + ": measurements changed since signed"), std::string::npos)
      << v.output;
}

TEST_F(ArchiveAttackTest, APlanSwappedWithItsDigestIsNamed) {
  // GIVEN the FAIL run's plan relaxed (its bias instability limit doubled)
  // and its sha256 column recomputed
  pb::TestPlan plan;
  ASSERT_TRUE(plan.ParseFromString(SignedSoak().plan_bytes));
  for (pb::Limit& limit : *plan.mutable_limits()) {
    if (limit.measurement() == "bias_instability") limit.set_high(2 * limit.high());
  }
  const std::string relaxed = plan.SerializeAsString();
  ASSERT_NE(relaxed, SignedSoak().plan_bytes);
  const std::string bad = SignedSoak().bad_run;
  Edit("UPDATE runs SET plan = X'" + HexString(relaxed) + "', plan_sha256 = '" +
       Sha256Hex(relaxed) + "' WHERE run_id = '" + bad + "'");
  const CommandResult v = Verify();
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_NE(v.output.find("run " + bad + ": plan does not match its signed digest"),
            std::string::npos)
      << v.output;
  EXPECT_EQ(std::count(v.output.begin(), v.output.end(), '\n'), 1) << v.output;
}

TEST_F(ArchiveAttackTest, AnOperatorOrAStationSwappedIsNamed) {
  const std::string& run = SignedSoak().runs[0];
  Edit("UPDATE runs SET operator = 'mallory' WHERE run_id = '" + run + "'");
  CommandResult v = Verify();
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_NE(v.output.find("run " + run +
                          ": operator changed since signed (signed 'ann', now "
                          "'mallory')"),
            std::string::npos)
      << v.output;
  Edit("UPDATE runs SET operator = 'ann', station = 'st2' WHERE run_id = '" + run + "'");
  v = Verify();
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_NE(
      v.output.find("run " + run + ": station changed since signed (signed 'st1', now 'st2')"),
      std::string::npos)
      << v.output;
  EXPECT_EQ(std::count(v.output.begin(), v.output.end(), '\n'), 1) << v.output;
}

TEST_F(ArchiveAttackTest, RawChunksDeletedAreNamed) {
  const std::string& run = SignedSoak().runs[1];
  Edit("DELETE FROM raw_chunks WHERE seq IN (10, 11, 12) AND run_key = " + Key(run));
  const CommandResult v = Verify();
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_NE(v.output.find("run " + run + ": 3 raw chunks deleted since signed (seq 10-12)"),
            std::string::npos)
      << v.output;
}

TEST_F(ArchiveAttackTest, AWholeFailRunDeletedBreaksTheChain) {
  // GIVEN the FAIL run gone, every row and its chain entry: the lot's yield
  // is 100 %
  const std::string bad = SignedSoak().bad_run;
  const int64_t entry =
      QueryInt(copy_, "SELECT entry FROM archive_chain WHERE run_id = '" + bad + "'");
  DeleteRun(bad);
  ASSERT_EQ(QueryInt(copy_, "SELECT COUNT(*) FROM runs WHERE verdict = 'FAIL'"), 0);
  const CommandResult v = Verify();
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_NE(v.output.find("chain: entry " + std::to_string(entry + 1) +
                          " follows a missing entry (entry " + std::to_string(entry) +
                          " deleted: a run was deleted)"),
            std::string::npos)
      << v.output;
}

TEST_F(ArchiveAttackTest, TheNewestRunDeletedWithItsEntryIsFoundAgainstTheKeptHead) {
  DeleteRun(SignedSoak().newest_run);
  // The chain alone is whole: three entries, each following the one before.
  const CommandResult alone = Verify();
  EXPECT_EQ(alone.exit_code, 0) << alone.output;
  // The head kept elsewhere finds it.
  const CommandResult v = Verify("--expect-head " + SignedSoak().head);
  EXPECT_EQ(v.exit_code, 1) << v.output;
  EXPECT_NE(v.output.find("chain: the kept head (entry 4) is missing: the chain ends at entry 3"),
            std::string::npos)
      << v.output;
}

// An archive this build made without a signing key: chained, unsigned.
TEST(ArchiveUnsignedTest, AnArchiveMadeWithoutAKeyReportsItsRunsUnsigned) {
  TempDir dir("archive_unsigned");
  const std::string db = dir.path("plain.db");
  const CommandResult run = RunCommand(Bin("imuqual") + " run --sim 1 --duration 300 " +
                                       "--short-soak --lot PLAIN --db " + db + " --quiet 2>&1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::string key = dir.path("store.key");
  ASSERT_EQ(RunCommand(Bin("imuqual") + " keygen --role store --out " + key + " 2>&1").exit_code,
            0);
  const std::string id = QueryText(db, "SELECT run_id FROM runs");
  // With --pubkey signatures are required: an unsigned entry is broken (an
  // attacker could have rebuilt the chain unsigned) ...
  const CommandResult required =
      RunCommand(Bin("imuqual") + " verify --db " + db + " --pubkey " + key + ".pub 2>&1");
  EXPECT_EQ(required.exit_code, 1) << required.output;
  EXPECT_NE(required.output.find("(run " + id + ") is unsigned, and signatures are required"),
            std::string::npos)
      << required.output;
  // ... unless the station ran without a signing key on purpose.
  const CommandResult v = RunCommand(Bin("imuqual") + " verify --db " + db + " --pubkey " + key +
                                     ".pub --allow-unsigned 2>&1");
  EXPECT_EQ(v.exit_code, 3) << v.output;
  EXPECT_NE(v.output.find("by a store without --sign-key; not verified): 1 run: " + id),
            std::string::npos)
      << v.output;
  EXPECT_EQ(v.output.find("signed and verified"), std::string::npos) << v.output;
  const CommandResult plain = RunCommand(Bin("imuqual") + " verify --db " + db + " 2>&1");
  EXPECT_EQ(plain.exit_code, 0) << plain.output;
}

// An archive of schema 6 (store/testdata/schema6_archive.sql) migrates in
// place; its runs are unsigned, never verified.
TEST(ArchiveUnsignedTest, AnArchiveOfSchema6MigratesAndReportsItsRunsUnsigned) {
  TempDir dir("archive_schema6");
  const std::string db = dir.path("s6.db");
  std::ifstream in(std::string(IMUQUAL_SOURCE_DIR) + "/store/testdata/schema6_archive.sql");
  std::stringstream dump;
  dump << in.rdbuf();
  {
    auto d = store::Db::Open(db, store::Db::Mode::kReadWrite);
    ASSERT_TRUE(d.ok());
    ASSERT_TRUE((*d)->Exec(dump.str()).ok());
  }
  ASSERT_EQ(QueryInt(db, "PRAGMA user_version"), 6);
  // Opened for writing once (a store starting on it): migrated.
  ASSERT_TRUE(store::Archive::Open(db, store::Archive::Mode::kWrite).ok());
  ASSERT_EQ(QueryInt(db, "PRAGMA user_version"), 7);
  const std::string key = dir.path("store.key");
  ASSERT_EQ(RunCommand(Bin("imuqual") + " keygen --role store --out " + key + " 2>&1").exit_code,
            0);
  const CommandResult v =
      RunCommand(Bin("imuqual") + " verify --db " + db + " --pubkey " + key + ".pub 2>&1");
  EXPECT_EQ(v.exit_code, 3) << v.output;
  EXPECT_NE(v.output.find("unsigned (2 archived before schema 7, 0 by a store without "
                          "--sign-key; not verified): 2 runs: S6-L001-U001-R1, S6-L001-U002-R1"),
            std::string::npos)
      << v.output;
  EXPECT_EQ(v.output.find("signed and verified"), std::string::npos) << v.output;
  const CommandResult head = RunCommand(Bin("imuqual") + " verify --db " + db + " --head");
  EXPECT_EQ(head.exit_code, 0);
  EXPECT_EQ(head.output.rfind("1:", 0), 0u) << head.output;
}

}  // namespace
}  // namespace imuqual
