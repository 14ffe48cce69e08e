#include "store/checksums.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <vector>

#include "common/crc32c.h"
#include "store/archive.h"

namespace imuqual::store {
namespace {

// Feeds values into a CRC-32C in a fixed little-endian layout, each value
// preceded by a type tag, so that no two different rows hash alike by
// shifting bytes from one column into the next.
class Hasher {
 public:
  void Tag(uint8_t tag) { Bytes(&tag, 1); }
  void Int(int64_t v) {
    uint8_t b[8];
    for (int i = 0; i < 8; ++i) b[i] = static_cast<uint8_t>(static_cast<uint64_t>(v) >> (8 * i));
    Bytes(b, 8);
  }
  void Real(double v) {
    int64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    Int(bits);
  }
  void Sized(const void* data, size_t size) {
    Int(static_cast<int64_t>(size));
    Bytes(data, size);
  }
  // The bytes go through the CRC a buffer at a time, not a value at a time
  // (a result's rows are thousands of 8-byte values): the CRC of the same
  // byte stream, whatever the pieces (Crc32cExtend).
  void Bytes(const void* data, size_t size) {
    if (size == 0) return;  // SQLite gives a null pointer for an empty text or blob
    if (fill_ + size > sizeof buffer_) Flush();
    if (size > sizeof buffer_) {
      crc_ = Crc32cExtend(crc_, data, size);
      return;
    }
    std::memcpy(buffer_ + fill_, data, size);
    fill_ += size;
  }
  uint32_t value() {
    Flush();
    return crc_;
  }

  // One column of the current row of `stmt`, tagged by its SQLite storage
  // class (the same tags for a plant archive's typed columns).
  void Column(const Stmt& stmt, int col) {
    switch (stmt.ColumnType(col)) {
      case Stmt::Type::kInt:
        Tag(SQLITE_INTEGER);
        Int(stmt.Int(col));
        break;
      case Stmt::Type::kReal:
        Tag(SQLITE_FLOAT);
        Real(stmt.Real(col));
        break;
      case Stmt::Type::kText: {
        Tag(SQLITE_TEXT);
        const std::string text = stmt.Text(col);
        Sized(text.data(), text.size());
        break;
      }
      case Stmt::Type::kBlob: {
        Tag(SQLITE_BLOB);
        const std::vector<uint8_t> blob = stmt.Blob(col);
        Sized(blob.data(), blob.size());
        break;
      }
      case Stmt::Type::kNull:
        Tag(SQLITE_NULL);  // the tag alone
        break;
    }
  }

 private:
  void Flush() {
    crc_ = Crc32cExtend(crc_, buffer_, fill_);
    fill_ = 0;
  }

  uint32_t crc_ = 0;
  uint8_t buffer_[4096];
  size_t fill_ = 0;
};

// The result rows of a run, table by table, in primary-key order. An
// optional query (added after schema 3) enters the checksum only when it
// returns rows, so checksums computed before it existed still hold.
struct ResultQuery {
  const char* sql;
  bool optional = false;
};
constexpr ResultQuery kResultQueries[] = {
    {"SELECT verdict, reasons, samples, gap_samples, invalid_samples, record, result_utime "
     "FROM runs WHERE run_key = ?"},
    {"SELECT axis_index, invalid_samples FROM run_axes WHERE run_key = ? ORDER BY axis_index"},
    {"SELECT axis, estimator, ci_method, tau0_s, samples, valid_samples, computed_utime "
     "FROM curves WHERE run_key = ? ORDER BY axis, estimator"},
    {"SELECT axis, estimator, m, tau_s, dev, lo, hi, edf, n_terms, stride "
     "FROM curve_points WHERE run_key = ? ORDER BY axis, estimator, m"},
    {"SELECT axis, name, value, uncertainty, unit, low, high, marginal_low, marginal_high, "
     "outcome, note FROM measurements WHERE run_key = ? ORDER BY axis, name"},
    {"SELECT revision, result_last_seq, result_gap_batches FROM runs WHERE run_key = ? AND "
     "(revision != 0 OR result_last_seq IS NOT NULL OR result_gap_batches IS NOT NULL)",
     true},
    {"SELECT revision, verdict, reasons, samples, gap_samples, record, result_utime, "
     "superseded_utime, cause FROM superseded_judgements WHERE run_key = ? ORDER BY revision",
     true},
    // Schema 6: what kind of value, how its uncertainty was obtained, the
    // decision rule; only the measurements that have any of them.
    {"SELECT axis, name, qualifier, uncertainty_method, decision_rule, guard_band "
     "FROM measurements WHERE run_key = ? AND (qualifier IS NOT NULL OR uncertainty_method IS "
     "NOT NULL OR decision_rule IS NOT NULL OR guard_band IS NOT NULL) ORDER BY axis, name",
     true},
    // Schema 6: the noise identification behind chi-square points.
    {"SELECT axis, estimator, m, alpha, alpha_from FROM curve_points WHERE run_key = ? AND "
     "(alpha IS NOT NULL OR alpha_from IS NOT NULL) ORDER BY axis, estimator, m",
     true},
};

std::string Hex(uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08X", v);
  return text;
}

// The stored 32-bit checksum of an INTEGER column.
uint32_t Stored(const Stmt& s, int col) { return static_cast<uint32_t>(s.Int(col)); }

// A chunk from a row whose columns 1..8 are seq, first_sample, num_samples,
// host_utime, temperature_c, codec, data, sample_utime (column 0: its run).
ChunkRecord ChunkFromRow(Stmt& row) {
  ChunkRecord c;
  c.seq = row.Int(1);
  c.first_sample = row.Int(2);
  c.num_samples = row.Int(3);
  c.host_utime = row.Int(4);
  if (!row.IsNull(5)) c.temperature_c = row.Real(5);
  c.codec = static_cast<int>(row.Int(6));
  c.data = row.Blob(7);
  c.sample_utime = row.Int(8);
  return c;
}

}  // namespace

uint32_t ChunkChecksum(const ChunkRecord& c) {
  Hasher h;
  h.Int(c.seq);
  h.Int(c.first_sample);
  h.Int(c.num_samples);
  h.Int(c.host_utime);
  h.Tag(c.temperature_c.has_value());
  h.Real(c.temperature_c.value_or(0.0));
  h.Int(c.codec);
  h.Int(c.sample_utime);
  h.Sized(c.data.data(), c.data.size());
  return h.value();
}

Result<uint32_t> ResultsChecksum(Db& db, int64_t run_key) {
  Hasher h;
  uint8_t table = 0;
  for (const ResultQuery& query : kResultQueries) {
    ++table;
    if (!query.optional) h.Tag(table);
    auto stmt = db.Prepare(query.sql);
    if (!stmt.ok()) return Status::IoError(stmt.status().message());
    stmt->Bind(1, run_key);
    bool first = true;
    for (;;) {
      auto row = stmt->Step();
      if (!row.ok()) {
        return Status::IoError(db.path() + ": reading results: " + row.status().message());
      }
      if (!*row) break;
      if (query.optional && first) h.Tag(table);
      first = false;
      h.Tag(0xFF);  // row separator
      for (int col = 0; col < stmt->ColumnCount(); ++col) h.Column(*stmt, col);
    }
  }
  return h.value();
}

Status SealResults(Db& db, int64_t run_key) {
  auto crc = ResultsChecksum(db, run_key);
  if (!crc.ok()) return crc.status();
  auto up = db.Prepare("UPDATE runs SET results_crc32c = ? WHERE run_key = ?");
  if (!up.ok()) return up.status();
  return up->Bind(1, static_cast<int64_t>(*crc)).Bind(2, run_key).Run();
}

Status ComputeMissingChecksums(Db& db) {
  auto chunks = db.Prepare(
      "SELECT run_key, seq, first_sample, num_samples, host_utime, temperature_c, codec, data, "
      "sample_utime FROM raw_chunks WHERE crc32c IS NULL");
  if (!chunks.ok()) return chunks.status();
  auto set_chunk = db.Prepare("UPDATE raw_chunks SET crc32c = ? WHERE run_key = ? AND seq = ?");
  if (!set_chunk.ok()) return set_chunk.status();
  for (;;) {
    auto row = chunks->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    const ChunkRecord c = ChunkFromRow(*chunks);
    IMUQUAL_RETURN_IF_ERROR(set_chunk->Bind(1, static_cast<int64_t>(ChunkChecksum(c)))
                                .Bind(2, chunks->Int(0))
                                .Bind(3, c.seq)
                                .Run());
  }
  auto runs = db.Prepare("SELECT run_key FROM runs WHERE results_crc32c IS NULL");
  if (!runs.ok()) return runs.status();
  std::vector<int64_t> keys;
  for (;;) {
    auto row = runs->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    keys.push_back(runs->Int(0));
  }
  for (int64_t key : keys) IMUQUAL_RETURN_IF_ERROR(SealResults(db, key));
  return Status::Ok();
}

Result<int64_t> CheckChecksums(Db& db, int64_t run_key,
                               const std::function<void(const std::string&)>& problem) {
  int64_t problems = 0;
  const std::string which = run_key >= 0 ? " WHERE r.run_key = ?" : "";
  auto chunks = db.Prepare(
      "SELECT r.run_id, c.seq, c.first_sample, c.num_samples, c.host_utime, c.temperature_c, "
      "c.codec, c.data, c.sample_utime, c.crc32c FROM raw_chunks c JOIN runs r USING (run_key)" +
      which + " ORDER BY c.run_key, c.seq");
  if (!chunks.ok()) return chunks.status();
  if (run_key >= 0) chunks->Bind(1, run_key);
  for (;;) {
    auto row = chunks->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    const ChunkRecord c = ChunkFromRow(*chunks);
    const std::string where = "run " + chunks->Text(0) + " chunk seq " + std::to_string(c.seq);
    if (chunks->IsNull(9)) {
      ++problems;
      problem(where + ": no checksum");
      continue;
    }
    const uint32_t computed = ChunkChecksum(c);
    if (computed != Stored(*chunks, 9)) {
      ++problems;
      problem(where + ": damaged (checksum " + Hex(Stored(*chunks, 9)) + ", contents give " +
              Hex(computed) + ")");
    }
  }
  // A run without results yet (still running) may have no checksum.
  auto runs = db.Prepare(
      "SELECT r.run_key, r.run_id, r.results_crc32c, r.result_utime IS NOT NULL OR EXISTS "
      "(SELECT 1 FROM curves c WHERE c.run_key = r.run_key) FROM runs r" +
      which + " ORDER BY r.run_key");
  if (!runs.ok()) return runs.status();
  if (run_key >= 0) runs->Bind(1, run_key);
  for (;;) {
    auto row = runs->Step();
    if (!row.ok()) return row.status();
    if (!*row) break;
    auto computed = ResultsChecksum(db, runs->Int(0));
    if (!computed.ok()) return computed.status();
    const std::string where = "run " + runs->Text(1) + " results";
    if (runs->IsNull(2)) {
      if (runs->Int(3) != 0) {
        ++problems;
        problem(where + ": no checksum");
      }
    } else if (*computed != Stored(*runs, 2)) {
      ++problems;
      problem(where + ": damaged (checksum " + Hex(Stored(*runs, 2)) + ", rows give " +
              Hex(*computed) + ")");
    }
  }
  return problems;
}

Result<int64_t> CheckIntegrity(Db& db, const std::function<void(const std::string&)>& problem) {
  auto s = db.Prepare("PRAGMA integrity_check");
  if (!s.ok()) {
    problem("integrity_check: " + s.status().message());
    return 1;
  }
  int64_t problems = 0;
  for (;;) {
    auto row = s->Step();
    if (!row.ok()) {
      problem("integrity_check: " + row.status().message());
      return problems + 1;
    }
    if (!*row) break;
    std::string line = s->Text(0);
    if (line == "ok") continue;
    std::replace(line.begin(), line.end(), '\n', ' ');  // one line per problem
    ++problems;
    problem("integrity_check: " + line);
  }
  return problems;
}

}  // namespace imuqual::store
