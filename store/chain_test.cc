// The canonical form, signed records and the hash chain (store/canonical.h,
// store/chain.h, store/chain_verify.h): records written by the archive
// verify; every kind of edit an attacker can make behind the store's back
// is named by the verification.
#include "store/chain.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "store/archive.h"
#include "store/chain_verify.h"
#include "store/checksums.h"
#include "store/chunk_codec.h"
#include "store/schema.h"

namespace imuqual::store {
namespace {

namespace fs = std::filesystem;

std::string ReadFileText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string Sha256Hex(const std::string& bytes) {
  uint8_t sha[crypto_hash_sha256_BYTES];
  crypto_hash_sha256(sha, reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
  return HexOf(sha, sizeof sha);
}

ChunkRecord Chunk(int64_t seq, std::optional<double> temperature = std::nullopt) {
  ChunkData d;
  d.num_axes = 1;
  d.num_samples = 8;
  for (int i = 0; i < 8; ++i) d.samples.push_back(static_cast<float>(seq * 10 + i));
  ChunkRecord c;
  c.seq = seq;
  c.first_sample = seq * 8;
  c.num_samples = 8;
  c.host_utime = 1000 + seq;
  c.sample_utime = 2000 + seq;
  c.temperature_c = temperature;
  c.codec = kCodecRawFloat32;
  c.data = EncodeChunk(d, kCodecRawFloat32);
  return c;
}

// What VerifyChain said.
struct Verified {
  std::vector<std::string> problems;
  ChainVerifyReport report;
  std::string Text() const {
    std::string t;
    for (const std::string& p : problems) t += p + "\n";
    return t;
  }
  bool Names(const std::string& text) const { return Text().find(text) != std::string::npos; }
};

class ChainTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("imuqual_chain_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    path_ = (dir_ / "a.db").string();
    auto key = GenerateSigningKey("store");
    ASSERT_TRUE(key.ok());
    key_ = *key;
    auto other = GenerateSigningKey("store");
    ASSERT_TRUE(other.ok());
    other_ = *other;
    auto a = Archive::Open(path_, Archive::Mode::kWrite);
    ASSERT_TRUE(a.ok()) << a.status().ToString();
    archive_ = std::move(*a);
    ASSERT_TRUE(archive_->SetSigningKey(key_).ok());
  }
  void TearDown() override {
    archive_.reset();
    fs::remove_all(dir_);
  }

  // A judged run of `chunks` chunks with a curve and two measurements,
  // finalised (and so signed) unless `finalize` is false.
  int64_t AddRun(const std::string& id, const std::string& verdict, int chunks = 5,
                 bool finalize = true) {
    RunInfo r;
    r.run_id = id;
    r.serial = "S-" + id;
    r.lot = "L1";
    r.station = "st1";
    r.slot = "1";
    r.operator_name = "ann";
    r.source = "sim";
    r.software_version = "1.0";
    r.start_utime = 100;
    r.nominal_rate_hz = 100;
    r.axes = {{"x", pb::GYRO}};
    r.plan = "plan of " + id;
    r.plan_sha256 = Sha256Hex(r.plan);
    r.state = "complete";
    r.last_seq = chunks - 1;
    EXPECT_TRUE(archive_->Begin().ok());
    const int64_t key = *archive_->UpsertRun(r);
    for (int s = 0; s < chunks; ++s) {
      EXPECT_TRUE(archive_
                      ->InsertChunk(key,
                                    Chunk(s, s % 2 ? std::optional<double>(25.0) : std::nullopt),
                                    nullptr)
                      .ok());
    }
    CurveRecord c;
    c.axis = "x";
    c.curve.tau0_s = 0.01;
    c.curve.points.push_back({});
    c.curve.points.back().m = 1;
    c.curve.points.back().tau_s = 0.01;
    c.curve.points.back().dev = 0.5;
    c.samples = chunks * 8;
    c.valid_samples = chunks * 8;
    EXPECT_TRUE(archive_->PutCurve(key, c).ok());
    ResultRecord res;
    res.verdict = verdict;
    res.reasons = {verdict == "FAIL" ? "x: bias_instability above its limit" : "all within limits"};
    res.samples = chunks * 8;
    res.result_utime = 500;
    res.last_seq = chunks - 1;
    res.gap_batches = 0;
    for (const char* name : {"bias_instability", "angle_random_walk"}) {
      pb::Measurement m;
      m.set_axis("x");
      m.set_name(name);
      m.set_value(verdict == "FAIL" ? 9.0 : 1.0);
      m.set_unit("deg/h");
      m.set_high(5.0);
      m.set_outcome(verdict == "FAIL" ? pb::FAIL : pb::PASS);
      res.measurements.push_back(m);
    }
    res.record = "record of " + id;
    EXPECT_TRUE(archive_->PutResult(key, res).ok());
    if (finalize) {
      EXPECT_TRUE(archive_->MarkFinalized(key, 600).ok());
    }
    EXPECT_TRUE(archive_->Commit().ok());
    return key;
  }

  Verified Verify(bool check_signatures = true, std::optional<ChainHead> head = std::nullopt,
                  std::vector<PublicKey> keys = {}) {
    Verified v;
    ChainVerifyOptions o;
    o.check_signatures = check_signatures;
    o.trusted = keys.empty() ? std::vector<PublicKey>{key_.Public()} : keys;
    o.expect_head = head;
    auto r = VerifyChain(archive_->db(), o, [&](const std::string& p) { v.problems.push_back(p); });
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    if (r.ok()) v.report = *r;
    return v;
  }

  // An edit behind the archive's back (the chain's triggers dropped first,
  // as an attacker would).
  void Edit(const std::string& sql) {
    ASSERT_TRUE(
        archive_->db()
            .Exec("PRAGMA foreign_keys = OFF; DROP TRIGGER IF EXISTS archive_chain_no_update; "
                  "DROP TRIGGER IF EXISTS archive_chain_no_delete; " +
                  sql)
            .ok())
        << sql;
  }

  fs::path dir_;
  std::string path_;
  SigningKey key_, other_;
  std::unique_ptr<Archive> archive_;
};

TEST(CanonicalTest, ValuesRoundTripAndRowsIgnoreOrderAndNulls) {
  ASSERT_TRUE(InitCrypto().ok());
  for (const CanonicalValue& v :
       {CanonicalValue::Integer(-5), CanonicalValue::Real(2.5), CanonicalValue::Text("ab\ncd"),
        CanonicalValue::Blob(std::string("\0\1", 2)), CanonicalValue::DigestOf(Digest{})}) {
    std::string bytes;
    v.AppendTo(&bytes);
    size_t pos = 0;
    CanonicalValue back;
    ASSERT_TRUE(CanonicalValue::Parse(bytes, &pos, &back));
    EXPECT_EQ(pos, bytes.size());
    EXPECT_EQ(back, v);
  }
  // The exact bytes of a value (SCHEMA.md): 'i' and 8 bytes little-endian.
  std::string bytes;
  CanonicalValue::Integer(258).AppendTo(&bytes);
  EXPECT_EQ(bytes, std::string("i\x02\x01\0\0\0\0\0\0", 9));
  // -0 is +0 (SQLite does not keep the sign of a zero).
  EXPECT_EQ(CanonicalValue::Real(-0.0), CanonicalValue::Real(0.0));
  EXPECT_FALSE(std::signbit(CanonicalValue::Real(-0.0).real));
  // A row is the same whatever the column order, and a NULL column is as
  // if it did not exist (a column added later leaves old rows' digests).
  const std::string row =
      EncodeRow({{"b", CanonicalValue::Integer(1)}, {"a", CanonicalValue::Text("x")}});
  EXPECT_EQ(row, EncodeRow({{"a", CanonicalValue::Text("x")},
                            {"b", CanonicalValue::Integer(1)},
                            {"c", CanonicalValue()}}));
  EXPECT_NE(row, EncodeRow({{"a", CanonicalValue::Text("x")}, {"b", CanonicalValue::Real(1)}}));
  // Truncated input is refused.
  size_t pos = 0;
  CanonicalValue v;
  EXPECT_FALSE(CanonicalValue::Parse(std::string("t\x05\0\0\0\0\0\0\0ab", 11), &pos, &v));
}

// The bytes store/SCHEMA.md defines, assembled here by hand from the text
// (what a plant archive reimplementing it would do), give the digests the
// archive computes.
std::string Le64(uint64_t v) {
  std::string b;
  for (int i = 0; i < 8; ++i) b.push_back(static_cast<char>(v >> (8 * i)));
  return b;
}
std::string Sized(const std::string& bytes) { return Le64(bytes.size()) + bytes; }
Digest Blake(const std::string& bytes) {
  Digest d;
  crypto_generichash(d.data(), d.size(), reinterpret_cast<const unsigned char*>(bytes.data()),
                     bytes.size(), nullptr, 0);
  return d;
}

TEST(CanonicalTest, DigestsAreTheBytesTheSchemaDocumentDefines) {
  ASSERT_TRUE(InitCrypto().ok());
  ChunkRecord c;
  c.seq = 3;
  c.first_sample = 300;
  c.num_samples = 2;
  c.host_utime = 7;
  c.temperature_c = 21.5;
  c.codec = 1;
  c.data = {0xAB, 0xCD};
  c.sample_utime = 9;
  double t = 21.5;
  uint64_t t_bits;
  std::memcpy(&t_bits, &t, sizeof t);
  const std::string row = Le64(8) + Sized("codec") + "i" + Le64(1) + Sized("data") + "b" +
                          Sized("\xAB\xCD") + Sized("first_sample") + "i" + Le64(300) +
                          Sized("host_utime") + "i" + Le64(7) + Sized("num_samples") + "i" +
                          Le64(2) + Sized("sample_utime") + "i" + Le64(9) + Sized("seq") + "i" +
                          Le64(3) + Sized("temperature_c") + "r" + Le64(t_bits);
  EXPECT_EQ(ChunkDigest(c), Blake(std::string("imuqual-chunk v1\0", 17) + row));
  // The chunk list: each seq and digest, then the count.
  ChunkListDigest list;
  list.Add(3, ChunkDigest(c));
  const Digest d = ChunkDigest(c);
  EXPECT_EQ(list.Final(),
            Blake(std::string("imuqual-chunks v1\0", 18) + Le64(3) +
                  std::string(reinterpret_cast<const char*>(d.data()), d.size()) + Le64(1)));
  // A chain entry's link hash over its body and its (empty) signature.
  ChainEntry e;
  e.entry = 1;
  e.kind = "finalized";
  e.run_id = "R";
  e.revision = 0;
  e.record = "rec";
  e.created_utime = 5;
  const Digest record = Blake("rec");
  const std::string body = std::string("imuqual-chain v1\0", 17) + Le64(1) + Sized("finalized") +
                           Sized("R") + Le64(0) +
                           std::string(reinterpret_cast<const char*>(record.data()), 32) + Le64(5) +
                           Sized("") + std::string(32, '\0');
  EXPECT_EQ(e.Body(), body);
  EXPECT_EQ(e.ComputeHash(), Blake(std::string("imuqual-chain-link v1\0", 22) + body + Le64(0)));
}

TEST(CanonicalTest, SeqRangesRoundTrip) {
  EXPECT_EQ(SeqRangesText({0, 1, 2, 4, 6, 7}), "0-2,4,6-7");
  EXPECT_EQ(SeqRangesText({}), "");
  std::vector<std::pair<int64_t, int64_t>> ranges;
  ASSERT_TRUE(ParseSeqRanges("0-2,4,6-7", &ranges));
  EXPECT_EQ(ranges, (std::vector<std::pair<int64_t, int64_t>>{{0, 2}, {4, 4}, {6, 7}}));
  EXPECT_FALSE(ParseSeqRanges("3-1", &ranges));
  EXPECT_FALSE(ParseSeqRanges("1,,2", &ranges));
}

TEST(CanonicalTest, SignedRecordRoundTripsAndRefusesMalformedBytes) {
  SignedRecord r;
  r.items["runs.verdict"] = CanonicalValue::Text("FAIL");
  r.items["runs.samples"] = CanonicalValue::Integer(10);
  const std::string bytes = r.Encode();
  auto back = SignedRecord::Decode(bytes);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->Encode(), bytes);
  EXPECT_FALSE(SignedRecord::Decode(bytes.substr(0, bytes.size() - 1)).ok());
  EXPECT_FALSE(SignedRecord::Decode(bytes + "x").ok());
}

// The digest the store computes when it writes a chunk is the one verify
// recomputes from the row, generically over raw_chunks' columns: a column
// added to raw_chunks and not to ChunkDigest fails here.
TEST_F(ChainTest, ChunkDigestAtWriteEqualsTheDigestOfTheRowReadBack) {
  ASSERT_TRUE(archive_->Begin().ok());
  RunInfo r;
  r.run_id = "R";
  r.serial = "S";
  r.lot = "L";
  r.axes = {{"x", pb::GYRO}};
  const int64_t key = *archive_->UpsertRun(r);
  const std::vector<std::optional<double>> temperatures = {std::nullopt, 25.0, -0.0, std::nan(""),
                                                           21.375};
  for (size_t i = 0; i < temperatures.size(); ++i) {
    ASSERT_TRUE(
        archive_->InsertChunk(key, Chunk(static_cast<int64_t>(i), temperatures[i]), nullptr).ok());
  }
  ASSERT_TRUE(archive_->Commit().ok());
  auto raw = archive_->db().Prepare("SELECT * FROM raw_chunks ORDER BY seq");
  ASSERT_TRUE(raw.ok());
  size_t rows = 0;
  while (*raw->Step()) {
    const CanonicalRow row = RowFromStatement(*raw, ChunkDigestExclusions());
    const Digest expected = ChunkDigest(Chunk(static_cast<int64_t>(rows), temperatures[rows]));
    const CanonicalRow all = RowFromStatement(*raw, {});
    const CanonicalValue* stored = nullptr;
    for (const auto& [name, value] : all) {
      if (name == "digest") stored = &value;
    }
    ASSERT_NE(stored, nullptr);
    EXPECT_EQ(ChunkRowDigest(row), expected) << "seq " << rows;
    EXPECT_EQ(stored->bytes, std::string(reinterpret_cast<const char*>(expected.data()), 32));
    ++rows;
  }
  EXPECT_EQ(rows, temperatures.size());
}

// The signer reads a run's chunk digests from the covering index, never the
// chunks' rows (their samples).
TEST_F(ChainTest, TheSignerReadsChunkDigestsFromTheCoveringIndex) {
  sqlite3_stmt* raw = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(archive_->db().handle(),
                               "EXPLAIN QUERY PLAN SELECT seq, digest FROM raw_chunks INDEXED BY "
                               "raw_chunks_digests WHERE run_key = 1 ORDER BY seq",
                               -1, &raw, nullptr),
            SQLITE_OK);
  std::string plan;
  while (sqlite3_step(raw) == SQLITE_ROW) {
    plan += reinterpret_cast<const char*>(sqlite3_column_text(raw, 3));
    plan += "\n";
  }
  sqlite3_finalize(raw);
  EXPECT_NE(plan.find("COVERING INDEX raw_chunks_digests"), std::string::npos) << plan;
}

TEST_F(ChainTest, AnUneditedArchiveVerifiesAndEachRunIsSignedInOrder) {
  AddRun("A", "PASS");
  AddRun("B", "FAIL");
  AddRun("C", "PASS", 5, /*finalize=*/false);
  const Verified v = Verify();
  EXPECT_TRUE(v.problems.empty()) << v.Text();
  EXPECT_EQ(v.report.verified, (std::vector<std::string>{"A", "B"}));
  EXPECT_EQ(v.report.open, (std::vector<std::string>{"C"}));
  EXPECT_EQ(v.report.head.entries, 2);
  auto chain = ReadChain(archive_->db());
  ASSERT_TRUE(chain.ok());
  ASSERT_EQ(chain->size(), 2u);
  EXPECT_EQ((*chain)[0].run_id, "A");
  EXPECT_EQ((*chain)[1].prev_hash, (*chain)[0].entry_hash);
  EXPECT_EQ((*chain)[1].key_id, key_.Public().Id());
  // Without keys: signed, not checked.
  const Verified unchecked = Verify(/*check_signatures=*/false);
  EXPECT_TRUE(unchecked.problems.empty());
  EXPECT_EQ(unchecked.report.signed_unchecked.size(), 2u);
  EXPECT_TRUE(unchecked.report.verified.empty());
  // The chain is append-only for honest tools.
  EXPECT_FALSE(archive_->db().Exec("DELETE FROM archive_chain WHERE entry = 2").ok());
  EXPECT_FALSE(archive_->db().Exec("UPDATE archive_chain SET run_id = 'X'").ok());
}

TEST_F(ChainTest, AVerdictEditedWithItsChecksumRecomputedIsNamed) {
  const int64_t key = AddRun("A", "FAIL");
  Edit("UPDATE runs SET verdict = 'PASS' WHERE run_id = 'A'");
  ASSERT_TRUE(SealResults(archive_->db(), key).ok());  // the CRC recomputed, as an attacker can
  std::vector<std::string> damage;
  ASSERT_EQ(*CheckChecksums(archive_->db(), -1, [&](const std::string& p) { damage.push_back(p); }),
            0);
  const Verified v = Verify();
  ASSERT_EQ(v.problems.size(), 1u) << v.Text();
  EXPECT_EQ(v.problems[0], "run A: verdict changed since signed (signed 'FAIL', now 'PASS')");
  EXPECT_TRUE(v.report.verified.empty());
}

TEST_F(ChainTest, IdentityPlanMeasurementsAndChunkEditsAreNamed) {
  AddRun("A", "PASS");
  AddRun("B", "FAIL");
  AddRun("C", "PASS", 10);
  AddRun("D", "PASS");
  Edit("UPDATE runs SET operator = 'eve' WHERE run_id = 'A'");
  Edit("UPDATE runs SET plan = CAST('other plan' AS BLOB), plan_sha256 = '" +
       Sha256Hex("other plan") + "' WHERE run_id = 'B'");
  Edit("UPDATE runs SET station = 'st9' WHERE run_id = 'B'");
  Edit(
      "DELETE FROM raw_chunks WHERE run_key = (SELECT run_key FROM runs WHERE run_id = 'C') "
      "AND seq IN (3, 4, 7)");
  Edit(
      "UPDATE measurements SET outcome = 'FAIL' WHERE run_key = (SELECT run_key FROM runs WHERE "
      "run_id = 'D') AND name = 'angle_random_walk'");
  const Verified v = Verify();
  EXPECT_TRUE(v.Names("run A: operator changed since signed (signed 'ann', now 'eve')"))
      << v.Text();
  EXPECT_TRUE(
      v.Names("run B: plan does not match its signed digest (plan bytes and plan_sha256 "
              "changed since signed)"))
      << v.Text();
  EXPECT_TRUE(v.Names("run B: station changed since signed (signed 'st1', now 'st9')")) << v.Text();
  EXPECT_TRUE(v.Names("run C: 3 raw chunks deleted since signed (seq 3-4,7)")) << v.Text();
  EXPECT_TRUE(v.Names("run D: measurements changed since signed (2 rows signed, 2 now)"))
      << v.Text();
  EXPECT_EQ(v.problems.size(), 5u) << v.Text();
  EXPECT_TRUE(v.report.verified.empty());
}

TEST_F(ChainTest, PlanBytesMustHashToTheirSignedSha256) {
  AddRun("A", "PASS");
  Edit("UPDATE runs SET plan = CAST('relaxed plan' AS BLOB) WHERE run_id = 'A'");
  const Verified v = Verify();
  EXPECT_TRUE(v.Names("run A: its plan bytes do not hash to its plan_sha256")) << v.Text();
  EXPECT_TRUE(v.Names("run A: plan does not match its signed digest (plan changed since signed)"))
      << v.Text();
  EXPECT_EQ(v.problems.size(), 2u) << v.Text();
}

TEST_F(ChainTest, ChunksChangedWithTheirDigestsAndChecksumsRecomputedAreFound) {
  const int64_t key = AddRun("A", "PASS");
  // Chunk 2's data replaced by chunk 3's, its CRC and its digest recomputed.
  ChunkRecord forged = Chunk(3);
  forged.seq = 2;
  forged.first_sample = 16;
  forged.host_utime = 1002;
  forged.sample_utime = 2002;
  auto up = archive_->db().Prepare(
      "UPDATE raw_chunks SET data = ?, crc32c = ?, digest = ? WHERE run_key = ? AND seq = 2");
  ASSERT_TRUE(up.ok());
  ASSERT_TRUE(up->BindBlob(1, forged.data)
                  .Bind(2, static_cast<int64_t>(ChunkChecksum(forged)))
                  .BindBlob(3, ChunkDigest(forged))
                  .Bind(4, key)
                  .Run()
                  .ok());
  Verified v = Verify();
  ASSERT_EQ(v.problems.size(), 1u) << v.Text();
  EXPECT_NE(v.problems[0].find("run A: raw chunks changed since signed"), std::string::npos);
  // Changed without the digest recomputed: named chunk by chunk.
  Edit("UPDATE raw_chunks SET host_utime = 7 WHERE seq = 4");
  ASSERT_TRUE(archive_->db().Exec("UPDATE raw_chunks SET crc32c = NULL WHERE seq = 4").ok());
  v = Verify();
  EXPECT_TRUE(
      v.Names("run A: 1 raw chunk changed since written (seq 4): their bytes do not match "
              "their digests"))
      << v.Text();
}

TEST_F(ChainTest, DeletedRunsAndEntriesBreakTheChainOrTheKeptHead) {
  AddRun("A", "PASS");
  AddRun("B", "FAIL");
  AddRun("C", "PASS");
  AddRun("D", "PASS");
  auto head = ReadChainHead(archive_->db());
  ASSERT_TRUE(head.ok());
  EXPECT_EQ(head->entries, 4);
  ChainHead parsed;
  ASSERT_TRUE(ChainHead::Parse(head->ToText(), &parsed));
  EXPECT_EQ(parsed.hash, head->hash);
  EXPECT_TRUE(Verify(true, *head).problems.empty());
  // GIVEN the FAIL run deleted, rows and chain entry
  auto del_run = [&](const std::string& id) {
    for (const char* table : {"measurements", "curve_points", "curves", "raw_chunks", "gaps",
                              "run_axes", "superseded_judgements"}) {
      Edit(std::string("DELETE FROM ") + table +
           " WHERE run_key = (SELECT run_key FROM runs WHERE run_id = '" + id + "')");
    }
    Edit("DELETE FROM runs WHERE run_id = '" + id +
         "'; DELETE FROM archive_chain WHERE run_id = '" + id + "'");
  };
  del_run("B");
  Verified v = Verify();
  ASSERT_EQ(v.problems.size(), 1u) << v.Text();
  EXPECT_EQ(v.problems[0],
            "chain: entry 3 follows a missing entry (entry 2 deleted: a run was deleted)");
  // AND the newest run deleted with its entry: the chain alone is intact,
  // the kept head finds it.
  del_run("D");
  v = Verify(true, *head);
  EXPECT_TRUE(v.Names("chain: the kept head (entry 4) is missing: the chain ends at entry 3"))
      << v.Text();
  // A run deleted but its entry kept is named.
  Edit("DELETE FROM runs WHERE run_id = 'C'");
  v = Verify();
  EXPECT_TRUE(v.Names("run C: deleted from the archive (chain entry 3 records it)")) << v.Text();
}

TEST_F(ChainTest, SignaturesByAnUnknownKeyOrAnotherRoleAreNamed) {
  AddRun("A", "PASS");
  Verified v = Verify(true, std::nullopt, {other_.Public()});
  ASSERT_EQ(v.problems.size(), 1u) << v.Text();
  EXPECT_EQ(v.problems[0],
            "run A: signed by an unknown key (key id " + key_.Public().Id() + ", chain entry 1)");
  // A run re-signed by someone else's store key (a whole entry rewritten)
  // is as unknown; an entry changed without its signature fails it.
  PublicKey wrong_role = key_.Public();
  wrong_role.role = "acquire";
  v = Verify(true, std::nullopt, {wrong_role});
  EXPECT_TRUE(v.Names("not a store key")) << v.Text();
  Edit("UPDATE archive_chain SET created_utime = 1, entry_hash = X'00' WHERE entry = 1");
  v = Verify();
  EXPECT_TRUE(v.Names("was changed since it was written")) << v.Text();
  EXPECT_TRUE(v.Names("run A: the signature of chain entry 1 does not verify")) << v.Text();
}

TEST_F(ChainTest, WithoutAKeyRunsAreChainedUnsignedAndNeverVerified) {
  auto plain = Archive::Open(path_, Archive::Mode::kWrite);
  ASSERT_TRUE(plain.ok());
  archive_ = std::move(*plain);  // no signing key
  AddRun("A", "PASS");
  Verified v = Verify();
  EXPECT_TRUE(v.problems.empty()) << v.Text();
  EXPECT_EQ(v.report.unsigned_keyless, (std::vector<std::string>{"A"}));
  EXPECT_TRUE(v.report.verified.empty());
  // An unsigned entry after a signed one: signatures stripped, or a store
  // without its key.
  ASSERT_TRUE(archive_->SetSigningKey(key_).ok());
  AddRun("B", "PASS");
  auto unsigned_again = Archive::Open(path_, Archive::Mode::kWrite);
  ASSERT_TRUE(unsigned_again.ok());
  archive_ = std::move(*unsigned_again);
  AddRun("C", "PASS");
  v = Verify();
  EXPECT_TRUE(v.Names("chain: entry 3 (run C) is unsigned although entry 2 before it is signed"))
      << v.Text();
  EXPECT_EQ(v.report.verified, (std::vector<std::string>{"B"}));
  // A signing key of another role is refused.
  auto acquire = GenerateSigningKey("acquire");
  ASSERT_TRUE(acquire.ok());
  EXPECT_FALSE(archive_->SetSigningKey(*acquire).ok());
}

TEST_F(ChainTest, AReopenedRunIsAnEntryOfItsOwnAndVerifiesOnceFinalisedAgain) {
  const int64_t key = AddRun("A", "FAIL");
  ASSERT_TRUE(archive_->Begin().ok());
  auto revision = archive_->SupersedeJudgement(key, 700, "acquire announced the run going on");
  ASSERT_TRUE(revision.ok()) << revision.status().ToString();
  ASSERT_TRUE(archive_->Commit().ok());
  // Open: the settled part is checked, the run is listed open.
  Verified v = Verify();
  EXPECT_TRUE(v.problems.empty()) << v.Text();
  EXPECT_EQ(v.report.open, (std::vector<std::string>{"A"}));
  // More chunks arrive while the round is open: fine.
  ASSERT_TRUE(archive_->InsertChunk(key, Chunk(5), nullptr).ok());
  EXPECT_TRUE(Verify().problems.empty());
  // The superseded judgement is settled: an edit of it is named.
  Edit("UPDATE superseded_judgements SET verdict = 'PASS'");
  v = Verify();
  EXPECT_TRUE(v.Names("run A: superseded_judgements changed since signed")) << v.Text();
  Edit("UPDATE superseded_judgements SET verdict = 'FAIL'");
  // Judged again and finalised: verified, three entries.
  ResultRecord res;
  res.verdict = "PASS";
  res.samples = 48;
  res.result_utime = 800;
  res.revision = *revision;
  ASSERT_TRUE(archive_->Begin().ok());
  ASSERT_TRUE(archive_->PutResult(key, res).ok());
  ASSERT_TRUE(archive_->MarkFinalized(key, 900).ok());
  ASSERT_TRUE(archive_->Commit().ok());
  v = Verify();
  EXPECT_TRUE(v.problems.empty()) << v.Text();
  EXPECT_EQ(v.report.verified, (std::vector<std::string>{"A"}));
  auto chain = ReadChain(archive_->db());
  ASSERT_EQ(chain->size(), 3u);
  EXPECT_EQ((*chain)[1].kind, kEntryReopened);
  EXPECT_EQ((*chain)[2].revision, 1);
}

// Columns and tables added later are covered by default, and leave the
// records signed before them valid while they are NULL or empty.
TEST_F(ChainTest, ColumnsAndTablesAddedLaterAreCoveredByDefault) {
  AddRun("A", "PASS");
  ASSERT_TRUE(archive_->db()
                  .Exec("ALTER TABLE runs ADD COLUMN chamber_humidity TEXT; "
                        "CREATE TABLE run_notes (run_key INTEGER, note TEXT)")
                  .ok());
  EXPECT_TRUE(Verify().problems.empty());
  AddRun("B", "PASS");
  ASSERT_TRUE(
      archive_->db().Exec("UPDATE runs SET chamber_humidity = '41 %' WHERE run_id = 'B'").ok());
  ASSERT_TRUE(
      archive_->db()
          .Exec(
              "INSERT INTO run_notes VALUES ((SELECT run_key FROM runs WHERE run_id = 'A'), 'hi')")
          .ok());
  const Verified v = Verify();
  EXPECT_TRUE(v.Names("run B: chamber_humidity changed since signed (signed NULL, now '41 %')"))
      << v.Text();
  EXPECT_TRUE(v.Names("run A: run_notes changed since signed (0 rows signed, 1 now)")) << v.Text();
}

// Two stores writing one file (or a store restarted): each appends in its
// own transaction after the entry it reads there, so the chain stays whole.
TEST_F(ChainTest, TwoWritersSharingAFileKeepOneChain) {
  auto second = Archive::Open(path_, Archive::Mode::kWrite);
  ASSERT_TRUE(second.ok());
  ASSERT_TRUE((*second)->SetSigningKey(other_).ok());
  AddRun("A", "PASS");
  std::swap(archive_, *second);
  AddRun("B", "PASS");
  std::swap(archive_, *second);
  AddRun("C", "FAIL");
  const Verified v = Verify(true, std::nullopt, {key_.Public(), other_.Public()});
  EXPECT_TRUE(v.problems.empty()) << v.Text();
  EXPECT_EQ(v.report.verified.size(), 3u);
  EXPECT_EQ(v.report.head.entries, 3);
}

// An archive of schema 6 (two runs of imuqual-history-gen) migrates to 7:
// its runs are listed by the migration's entry and reported unsigned, never
// verified; a run finalised after the migration is signed.
TEST_F(ChainTest, RunsOfAnOlderArchiveAreReportedUnsigned) {
  archive_.reset();
  fs::remove(path_);
  auto dump = ReadFileText(std::string(IMUQUAL_SOURCE_DIR) + "/store/testdata/schema6_archive.sql");
  {
    auto db = Db::Open(path_, Db::Mode::kReadWrite);
    ASSERT_TRUE(db.ok());
    ASSERT_TRUE((*db)->Exec(dump).ok());
  }
  auto a = Archive::Open(path_, Archive::Mode::kWrite);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  archive_ = std::move(*a);
  ASSERT_TRUE(archive_->SetSigningKey(key_).ok());
  Verified v = Verify();
  EXPECT_TRUE(v.problems.empty()) << v.Text();
  EXPECT_EQ(v.report.unsigned_legacy.size(), 2u);
  EXPECT_TRUE(v.report.verified.empty());
  EXPECT_EQ(v.report.head.entries, 1);
  AddRun("NEW", "PASS");
  v = Verify();
  EXPECT_TRUE(v.problems.empty()) << v.Text();
  EXPECT_EQ(v.report.verified, (std::vector<std::string>{"NEW"}));
  // A legacy run deleted (it has no signature of its own) is still named:
  // the migration's entry lists it.
  Edit(
      "DELETE FROM measurements WHERE run_key = (SELECT run_key FROM runs WHERE run_id = "
      "'S6-L001-U002-R1'); DELETE FROM runs WHERE run_id = 'S6-L001-U002-R1'");
  v = Verify();
  EXPECT_TRUE(
      v.Names("run S6-L001-U002-R1: deleted from the archive (listed by the migration to "
              "schema 7, chain entry 1)"))
      << v.Text();
  // A legacy run's listing cannot be changed without breaking the chain.
  Edit("UPDATE archive_chain SET record = X'00' WHERE entry = 1");
  v = Verify();
  EXPECT_FALSE(v.problems.empty());
}

// A run open across the upgrade: its chunks written before have no digest;
// they get one when the run is finalised and signed.
TEST_F(ChainTest, ChunksWrittenBeforeSchema7GetTheirDigestsAtSigning) {
  const int64_t key = AddRun("A", "PASS", 6, /*finalize=*/false);
  ASSERT_TRUE(archive_->db().Exec("UPDATE raw_chunks SET digest = NULL WHERE seq < 3").ok());
  ASSERT_TRUE(archive_->Begin().ok());
  ASSERT_TRUE(archive_->MarkFinalized(key, 600).ok());
  ASSERT_TRUE(archive_->Commit().ok());
  EXPECT_EQ(*archive_->db().QueryInt("SELECT COUNT(*) FROM raw_chunks WHERE digest IS NULL"), 0);
  const Verified v = Verify();
  EXPECT_TRUE(v.problems.empty()) << v.Text();
  EXPECT_EQ(v.report.verified, (std::vector<std::string>{"A"}));
}

}  // namespace
}  // namespace imuqual::store
