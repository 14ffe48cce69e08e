// The canonical form of archived rows, from which the archive's digests and
// signed records are computed (store/SCHEMA.md, "Signed records and the
// chain", is the exact definition; this is its one implementation). It
// depends only on each value's type and bytes and on column names, never on
// SQLite's internals (rowids, pages, storage order), so that a plant archive
// on another database can recompute every digest after shipping.
//
// - A value: NULL is left out (a column added later, NULL for older rows,
//   leaves their digests as they were); integer 'i' + 8 bytes two's
//   complement little-endian; real 'r' + 8 bytes IEEE 754 binary64
//   little-endian (-0 written as +0: SQLite does not keep the sign of a
//   zero); text 't' + u64 length + UTF-8 bytes; blob 'b' + u64 length +
//   bytes; a blob's digest 'd' + its 32 bytes (signed records only).
// - A row: u64 number of non-NULL columns, then each as u64 name length,
//   name and value, in ascending bytewise order of the names.
// - Digests: BLAKE2b-256 (libsodium crypto_generichash, unkeyed, 32 bytes).
//
// Thread-safety: functions are thread-safe; objects are values used by one
// thread at a time.
#ifndef IMUQUAL_STORE_CANONICAL_H_
#define IMUQUAL_STORE_CANONICAL_H_

#include <sodium.h>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "store/sqlite.h"

namespace imuqual::store {

struct ChunkRecord;

inline constexpr size_t kDigestBytes = 32;
using Digest = std::array<uint8_t, kDigestBytes>;

// BLAKE2b-256 fed incrementally (call InitCrypto() once before use: the
// archive does on open).
class Blake2b256 {
 public:
  Blake2b256();
  void Update(const void* data, size_t size);
  void Update(std::string_view bytes) { Update(bytes.data(), bytes.size()); }
  // Length-prefixed: u64 little-endian size, then the bytes.
  void Sized(std::string_view bytes);
  void U64(uint64_t v);
  void I64(int64_t v) { U64(static_cast<uint64_t>(v)); }
  Digest Final();

 private:
  crypto_generichash_state state_;
};

Digest Blake2b256Of(std::string_view bytes);

// Appends the canonical little-endian encodings.
void AppendU64(std::string* out, uint64_t v);
void AppendSized(std::string* out, std::string_view bytes);

// One typed value of the canonical form.
struct CanonicalValue {
  enum class Type : char {
    kNull = 0,
    kInteger = 'i',
    kReal = 'r',
    kText = 't',
    kBlob = 'b',
    kDigest = 'd',  // a blob represented by its BLAKE2b-256 (signed records)
  };
  Type type = Type::kNull;
  int64_t integer = 0;
  double real = 0;
  std::string bytes;  // text, blob or the digest's 32 bytes

  static CanonicalValue Integer(int64_t v);
  static CanonicalValue Real(double v);  // -0 becomes +0
  static CanonicalValue Text(std::string_view v);
  static CanonicalValue Blob(std::string_view v);
  static CanonicalValue DigestOf(const Digest& d);
  // The value of column `col` of the statement's current row (by its
  // storage class, which the archive's typed columns keep).
  static CanonicalValue FromColumn(const Stmt& stmt, int col);

  bool is_null() const { return type == Type::kNull; }
  // Appends the encoding (precondition: not NULL).
  void AppendTo(std::string* out) const;
  // Parses one value at `*pos` of `in`, advancing it; false if malformed.
  static bool Parse(std::string_view in, size_t* pos, CanonicalValue* out);
  // For messages: a number, 'text' (shortened past 60 characters), "N
  // bytes" or "digest HEX...".
  std::string Display() const;

  friend bool operator==(const CanonicalValue& a, const CanonicalValue& b);
  friend bool operator!=(const CanonicalValue& a, const CanonicalValue& b) { return !(a == b); }
};

// A row as (column name, value) pairs; NULL values are left out by
// EncodeRow, the order of `row` does not matter.
using CanonicalRow = std::vector<std::pair<std::string, CanonicalValue>>;
std::string EncodeRow(CanonicalRow row);

// Every column of the statement's current row, by name, but those named in
// `excluded` (NULLs kept as kNull; EncodeRow leaves them out).
CanonicalRow RowFromStatement(const Stmt& stmt, const std::vector<std::string>& excluded);

// The columns of raw_chunks left out of a chunk's digest: its run (named by
// the run's record instead) and the chunk's own checksum and digest.
const std::vector<std::string>& ChunkDigestExclusions();

// BLAKE2b-256 of "imuqual-chunk v1\0" and the chunk's canonical row (every
// column of raw_chunks but ChunkDigestExclusions()). ChunkDigest computes it
// from the record the store writes (raw_chunks' columns in schema 7, named
// as in the table); ChunkRowDigest from a row as read back, generically.
Digest ChunkDigest(const ChunkRecord& chunk);
Digest ChunkRowDigest(const CanonicalRow& row);

// BLAKE2b-256 of "imuqual-chunks v1\0", then each chunk's i64 seq and 32-byte
// digest in ascending seq order, then u64 count: the run's ordered chunk list.
class ChunkListDigest {
 public:
  ChunkListDigest() { hash_.Update(std::string_view("imuqual-chunks v1\0", 18)); }
  // Seqs must come in ascending order.
  void Add(int64_t seq, const Digest& digest);
  int64_t count() const { return count_; }
  // The digest (the count goes last, so that chunks can stream in).
  Digest Final();

 private:
  Blake2b256 hash_;
  int64_t count_ = 0;
};

// Seqs as ranges, "0-99,101,103-200" ("" for none), ascending.
std::string SeqRangesText(const std::vector<int64_t>& ascending_seqs);
// The inverse; false if malformed.
bool ParseSeqRanges(std::string_view text, std::vector<std::pair<int64_t, int64_t>>* ranges);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_CANONICAL_H_
