#include "store/postgres.h"

#include <algorithm>
#include <cctype>

namespace imuqual::store {
namespace {

constexpr unsigned kByteaOid = 17;
// Statements kept prepared per connection; others run unnamed.
constexpr size_t kMaxPrepared = 256;

std::string FirstLine(const char* text) {
  std::string s = text ? text : "";
  const size_t end = s.find('\n');
  if (end != std::string::npos) s.resize(end);
  return s;
}

// A libpq URI without the password: postgresql://user:SECRET@host/db ->
// postgresql://user@host/db, and password=... in the query string dropped.
std::string WithoutPassword(const std::string& url) {
  std::string out = url;
  const size_t scheme = out.find("://");
  if (scheme != std::string::npos) {
    const size_t at = out.find('@', scheme + 3);
    const size_t slash = out.find('/', scheme + 3);
    if (at != std::string::npos && (slash == std::string::npos || at < slash)) {
      const size_t colon = out.find(':', scheme + 3);
      if (colon != std::string::npos && colon < at) out.erase(colon, at - colon);
    }
  }
  const size_t query = out.find('?');
  if (query == std::string::npos) return out;
  std::string kept;
  size_t start = query + 1;
  while (start <= out.size()) {
    size_t end = out.find('&', start);
    if (end == std::string::npos) end = out.size();
    const std::string part = out.substr(start, end - start);
    if (!part.empty() && !part.starts_with("password=")) kept += (kept.empty() ? "" : "&") + part;
    start = end + 1;
  }
  out.resize(query);
  if (!kept.empty()) out += "?" + kept;
  return out;
}

Status ErrorStatus(PGconn* conn, const PGresult* r, const std::string& what) {
  const char* state = r ? PQresultErrorField(r, PG_DIAG_SQLSTATE) : nullptr;
  const std::string msg = what + ": " + (r ? FirstLine(PQresultErrorMessage(r)) : PgError(conn));
  const std::string code = state ? state : "";
  if (PQstatus(conn) != CONNECTION_OK || code.starts_with("08") || code.starts_with("57P")) {
    return Status::Unavailable(msg);  // the server went away, or is shutting down
  }
  if (code == "40001" || code == "40P01" || code == "55P03") return Status::Unavailable(msg);
  if (code.starts_with("53")) return Status::IoError(msg);  // disk full, out of memory
  if (code.starts_with("XX")) return Status::Corruption(msg);
  return Status::InvalidArgument(msg);
}

std::string Brief(const std::string& sql) {
  const size_t start = sql.find_first_not_of(" \n\t");
  if (start == std::string::npos) return "";
  std::string s = sql.substr(start, sql.find('\n', start) - start);
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

}  // namespace

PgConnection::~PgConnection() {
  if (conn) PQfinish(conn);
}

std::string PgError(PGconn* conn) { return FirstLine(conn ? PQerrorMessage(conn) : "no connection"); }

Result<std::unique_ptr<PgConnection>> PgConnect(const std::string& url, bool read_only,
                                                std::string* label) {
  *label = WithoutPassword(url);
  auto c = std::make_unique<PgConnection>();
  // Over a network: give up connecting after 10 s, and on a peer silent for
  // 60 s, unless the URL says otherwise (a plant unreachable must not hang
  // a station's shipping for the kernel's minutes).
  std::string conninfo = url;
  for (const char* option : {"connect_timeout=10", "tcp_user_timeout=60000"}) {
    const std::string name = std::string(option).substr(0, std::string(option).find('='));
    if (conninfo.find(name + "=") != std::string::npos) continue;
    conninfo += (conninfo.find('?') == std::string::npos ? "?" : "&") + std::string(option);
  }
  c->conn = PQconnectdb(conninfo.c_str());
  if (c->conn == nullptr || PQstatus(c->conn) != CONNECTION_OK) {
    return Status::Unavailable("cannot connect to the plant archive " + *label + ": " +
                               PgError(c->conn));
  }
  PQsetErrorVerbosity(c->conn, PQERRORS_TERSE);
  std::string setup =
      "SET client_min_messages = warning; SET extra_float_digits = 3; SET TIME ZONE 'UTC';";
  if (read_only) setup += " SET default_transaction_read_only = on;";
  IMUQUAL_RETURN_IF_ERROR(PgExec(*c, setup, *label));
  return c;
}

std::string PgTranslate(std::string_view sql) {
  std::string out;
  out.reserve(sql.size() + 8);
  int next = 1;  // a bare ? takes the largest index so far + 1 (SQLite's rule)
  size_t i = 0;
  while (i < sql.size()) {
    const char ch = sql[i];
    if (ch == '\'' || ch == '"') {  // a literal or a quoted name, '' inside
      const size_t end = sql.find(ch, i + 1);
      const size_t stop = end == std::string_view::npos ? sql.size() : end + 1;
      out.append(sql.substr(i, stop - i));
      i = stop;
    } else if (ch == '-' && i + 1 < sql.size() && sql[i + 1] == '-') {
      const size_t end = sql.find('\n', i);
      const size_t stop = end == std::string_view::npos ? sql.size() : end;
      out.append(sql.substr(i, stop - i));
      i = stop;
    } else if (ch == '?') {
      size_t j = i + 1;
      while (j < sql.size() && std::isdigit(static_cast<unsigned char>(sql[j]))) ++j;
      int n = next;
      if (j > i + 1) n = std::stoi(std::string(sql.substr(i + 1, j - i - 1)));
      next = std::max(next, n + 1);
      out += "$" + std::to_string(n);
      i = j;
    } else {
      out += ch;
      ++i;
    }
  }
  return out;
}

PgQuery::~PgQuery() { Clear(); }

void PgQuery::Set(int i, std::optional<std::string> value, bool binary) {
  if (i < 1) return;
  const size_t n = static_cast<size_t>(i);
  if (values.size() < n) {
    values.resize(n);
    formats.resize(n, 0);
    types.resize(n, 0);
  }
  values[n - 1] = std::move(value);
  formats[n - 1] = binary ? 1 : 0;
  types[n - 1] = binary ? kByteaOid : 0;
}

void PgQuery::Clear() {
  if (result) PQclear(result);
  result = nullptr;
  row = -1;
  values.clear();
  formats.clear();
  types.clear();
}

Result<bool> PgStep(PgConnection& c, PgQuery& q, const std::string& label) {
  if (q.result == nullptr) {
    std::vector<const char*> values(q.values.size());
    std::vector<int> lengths(q.values.size());
    for (size_t k = 0; k < q.values.size(); ++k) {
      values[k] = q.values[k] ? q.values[k]->data() : nullptr;
      lengths[k] = q.values[k] ? static_cast<int>(q.values[k]->size()) : 0;
    }
    const int count = static_cast<int>(values.size());
    const unsigned* types = q.types.empty() ? nullptr : q.types.data();
    auto named = c.prepared.find(q.sql);
    if (named == c.prepared.end() && c.prepared.size() < kMaxPrepared) {
      // Prepared outside a transaction's failure: a statement that does not
      // compile is run unnamed below and reports its error there.
      const std::string name = "imuqual_" + std::to_string(c.prepared.size() + 1);
      PGresult* p = PQprepare(c.conn, name.c_str(), q.sql.c_str(), count, types);
      if (PQresultStatus(p) == PGRES_COMMAND_OK) named = c.prepared.emplace(q.sql, name).first;
      PQclear(p);
    }
    q.result = named != c.prepared.end()
                   ? PQexecPrepared(c.conn, named->second.c_str(), count, values.data(),
                                    lengths.data(), q.formats.data(), 0)
                   : PQexecParams(c.conn, q.sql.c_str(), count, types, values.data(), lengths.data(),
                                  q.formats.data(), 0);
    const ExecStatusType st = PQresultStatus(q.result);
    if (st == PGRES_COMMAND_OK) {
      const char* n = PQcmdTuples(q.result);
      c.changes = n && *n ? std::stoll(n) : 0;
      return false;
    }
    if (st != PGRES_TUPLES_OK) {
      Status error = ErrorStatus(c.conn, q.result, label + " [" + Brief(q.sql) + "]");
      PQclear(q.result);
      q.result = nullptr;
      return error;
    }
    const char* n = PQcmdTuples(q.result);
    c.changes = n && *n ? std::stoll(n) : 0;  // INSERT ... RETURNING
    q.row = 0;
  } else {
    ++q.row;
  }
  return q.row < PQntuples(q.result);
}

Status PgExec(PgConnection& c, const std::string& sql, const std::string& label) {
  PGresult* r = PQexec(c.conn, sql.c_str());
  const ExecStatusType st = PQresultStatus(r);
  Status out = st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK
                   ? Status::Ok()
                   : ErrorStatus(c.conn, r, label + " [" + Brief(sql) + "]");
  if (out.ok()) {
    const char* n = PQcmdTuples(r);
    c.changes = n && *n ? std::stoll(n) : 0;
  }
  PQclear(r);
  return out;
}

}  // namespace imuqual::store
