#include "store/canonical.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>

#include "common/keys.h"
#include "store/archive.h"

namespace imuqual::store {

Blake2b256::Blake2b256() { crypto_generichash_init(&state_, nullptr, 0, kDigestBytes); }

void Blake2b256::Update(const void* data, size_t size) {
  crypto_generichash_update(&state_, static_cast<const unsigned char*>(data), size);
}

void Blake2b256::U64(uint64_t v) {
  uint8_t b[8];
  for (int i = 0; i < 8; ++i) b[i] = static_cast<uint8_t>(v >> (8 * i));
  Update(b, sizeof b);
}

void Blake2b256::Sized(std::string_view bytes) {
  U64(bytes.size());
  Update(bytes);
}

Digest Blake2b256::Final() {
  Digest d;
  crypto_generichash_final(&state_, d.data(), d.size());
  return d;
}

Digest Blake2b256Of(std::string_view bytes) {
  Blake2b256 h;
  h.Update(bytes);
  return h.Final();
}

void AppendU64(std::string* out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<char>(static_cast<uint8_t>(v >> (8 * i))));
}

void AppendSized(std::string* out, std::string_view bytes) {
  AppendU64(out, bytes.size());
  out->append(bytes);
}

namespace {

uint64_t ReadU64(std::string_view in, size_t pos) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t{static_cast<uint8_t>(in[pos + i])} << (8 * i);
  return v;
}

}  // namespace

CanonicalValue CanonicalValue::Integer(int64_t v) {
  CanonicalValue c;
  c.type = Type::kInteger;
  c.integer = v;
  return c;
}

CanonicalValue CanonicalValue::Real(double v) {
  CanonicalValue c;
  c.type = Type::kReal;
  c.real = v == 0 ? 0.0 : v;  // -0 as +0
  return c;
}

CanonicalValue CanonicalValue::Text(std::string_view v) {
  CanonicalValue c;
  c.type = Type::kText;
  c.bytes = v;
  return c;
}

CanonicalValue CanonicalValue::Blob(std::string_view v) {
  CanonicalValue c;
  c.type = Type::kBlob;
  c.bytes = v;
  return c;
}

CanonicalValue CanonicalValue::DigestOf(const Digest& d) {
  CanonicalValue c;
  c.type = Type::kDigest;
  c.bytes.assign(reinterpret_cast<const char*>(d.data()), d.size());
  return c;
}

CanonicalValue CanonicalValue::FromColumn(const Stmt& stmt, int col) {
  switch (stmt.ColumnType(col)) {
    case Stmt::Type::kInt:
      return Integer(stmt.Int(col));
    case Stmt::Type::kReal:
      return Real(stmt.Real(col));
    case Stmt::Type::kText:
      return Text(stmt.Text(col));
    case Stmt::Type::kBlob: {
      const std::vector<uint8_t> bytes = stmt.Blob(col);
      return Blob(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    }
    default:
      return CanonicalValue();
  }
}

void CanonicalValue::AppendTo(std::string* out) const {
  out->push_back(static_cast<char>(type));
  switch (type) {
    case Type::kInteger:
      AppendU64(out, static_cast<uint64_t>(integer));
      break;
    case Type::kReal: {
      uint64_t bits;
      std::memcpy(&bits, &real, sizeof bits);
      AppendU64(out, bits);
      break;
    }
    case Type::kText:
    case Type::kBlob:
      AppendSized(out, bytes);
      break;
    case Type::kDigest:
      out->append(bytes);
      break;
    case Type::kNull:
      break;  // never encoded (precondition)
  }
}

bool CanonicalValue::Parse(std::string_view in, size_t* pos, CanonicalValue* out) {
  if (*pos >= in.size()) return false;
  const char tag = in[(*pos)++];
  auto need = [&](size_t n) { return in.size() - *pos >= n; };
  switch (tag) {
    case 'i':
    case 'r': {
      if (!need(8)) return false;
      const uint64_t bits = ReadU64(in, *pos);
      *pos += 8;
      if (tag == 'i') {
        *out = Integer(static_cast<int64_t>(bits));
      } else {
        double v;
        std::memcpy(&v, &bits, sizeof v);
        out->type = Type::kReal;
        out->real = v;
        out->bytes.clear();
      }
      return true;
    }
    case 't':
    case 'b': {
      if (!need(8)) return false;
      const uint64_t size = ReadU64(in, *pos);
      *pos += 8;
      if (!need(size)) return false;
      const std::string_view bytes = in.substr(*pos, size);
      *pos += size;
      *out = tag == 't' ? Text(bytes) : Blob(bytes);
      return true;
    }
    case 'd': {
      if (!need(kDigestBytes)) return false;
      out->type = Type::kDigest;
      out->bytes.assign(in.substr(*pos, kDigestBytes));
      *pos += kDigestBytes;
      return true;
    }
    default:
      return false;
  }
}

std::string CanonicalValue::Display() const {
  switch (type) {
    case Type::kNull:
      return "NULL";
    case Type::kInteger:
      return std::to_string(integer);
    case Type::kReal: {
      char text[40];
      std::snprintf(text, sizeof text, "%.17g", real);
      return text;
    }
    case Type::kText: {
      constexpr size_t kShown = 60;
      std::string shown = bytes.size() > kShown ? bytes.substr(0, kShown) + "..." : bytes;
      std::replace(shown.begin(), shown.end(), '\n', ' ');
      return "'" + shown + "'";
    }
    case Type::kBlob:
      return std::to_string(bytes.size()) + " bytes";
    case Type::kDigest:
      return "digest " + HexOf(bytes.data(), 8) + "...";
  }
  return "";
}

bool operator==(const CanonicalValue& a, const CanonicalValue& b) {
  if (a.type != b.type) return false;
  switch (a.type) {
    case CanonicalValue::Type::kNull:
      return true;
    case CanonicalValue::Type::kInteger:
      return a.integer == b.integer;
    case CanonicalValue::Type::kReal:
      return std::memcmp(&a.real, &b.real, sizeof a.real) == 0;  // bit for bit
    default:
      return a.bytes == b.bytes;
  }
}

std::string EncodeRow(CanonicalRow row) {
  std::erase_if(row, [](const auto& column) { return column.second.is_null(); });
  std::sort(row.begin(), row.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });  // bytewise
  std::string out;
  AppendU64(&out, row.size());
  for (const auto& [name, value] : row) {
    AppendSized(&out, name);
    value.AppendTo(&out);
  }
  return out;
}

CanonicalRow RowFromStatement(const Stmt& stmt, const std::vector<std::string>& excluded) {
  CanonicalRow row;
  const int columns = stmt.ColumnCount();
  for (int col = 0; col < columns; ++col) {
    const std::string name = stmt.ColumnName(col);
    if (std::find(excluded.begin(), excluded.end(), name) != excluded.end()) continue;
    row.emplace_back(name, CanonicalValue::FromColumn(stmt, col));
  }
  return row;
}

const std::vector<std::string>& ChunkDigestExclusions() {
  static const std::vector<std::string> kExcluded = {"run_key", "crc32c", "digest"};
  return kExcluded;
}

Digest ChunkRowDigest(const CanonicalRow& row) {
  Blake2b256 h;
  h.Update(std::string_view("imuqual-chunk v1\0", 17));
  h.Update(EncodeRow(row));
  return h.Final();
}

Digest ChunkDigest(const ChunkRecord& c) {
  // The columns of raw_chunks as Archive::InsertChunk writes them (a
  // temperature that is absent or NaN is NULL there).
  CanonicalRow row = {
      {"seq", CanonicalValue::Integer(c.seq)},
      {"first_sample", CanonicalValue::Integer(c.first_sample)},
      {"num_samples", CanonicalValue::Integer(c.num_samples)},
      {"host_utime", CanonicalValue::Integer(c.host_utime)},
      {"codec", CanonicalValue::Integer(c.codec)},
      {"data", CanonicalValue::Blob({reinterpret_cast<const char*>(c.data.data()), c.data.size()})},
      {"sample_utime", CanonicalValue::Integer(c.sample_utime)},
  };
  if (c.temperature_c && !std::isnan(*c.temperature_c)) {
    row.emplace_back("temperature_c", CanonicalValue::Real(*c.temperature_c));
  }
  return ChunkRowDigest(row);
}

void ChunkListDigest::Add(int64_t seq, const Digest& digest) {
  hash_.I64(seq);
  hash_.Update(digest.data(), digest.size());
  ++count_;
}

Digest ChunkListDigest::Final() {
  hash_.U64(static_cast<uint64_t>(count_));
  return hash_.Final();
}

std::string SeqRangesText(const std::vector<int64_t>& seqs) {
  std::string out;
  for (size_t i = 0; i < seqs.size();) {
    size_t j = i;
    while (j + 1 < seqs.size() && seqs[j + 1] == seqs[j] + 1) ++j;
    if (!out.empty()) out += ',';
    out += std::to_string(seqs[i]);
    if (j > i) {
      out += '-';
      out += std::to_string(seqs[j]);
    }
    i = j + 1;
  }
  return out;
}

bool ParseSeqRanges(std::string_view text, std::vector<std::pair<int64_t, int64_t>>* ranges) {
  ranges->clear();
  if (text.empty()) return true;
  size_t pos = 0;
  for (;;) {
    int64_t first = 0, last = 0;
    auto r = std::from_chars(text.data() + pos, text.data() + text.size(), first);
    if (r.ec != std::errc()) return false;
    pos = static_cast<size_t>(r.ptr - text.data());
    last = first;
    if (pos < text.size() && text[pos] == '-') {
      r = std::from_chars(text.data() + pos + 1, text.data() + text.size(), last);
      if (r.ec != std::errc() || last < first) return false;
      pos = static_cast<size_t>(r.ptr - text.data());
    }
    ranges->emplace_back(first, last);
    if (pos == text.size()) return true;
    if (text[pos] != ',') return false;
    ++pos;
  }
}

}  // namespace imuqual::store
