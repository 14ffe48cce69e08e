// A thin RAII layer over the SQLite C API that reports failures as Status
// values naming the statement and SQLite's message. Bound parameters only:
// no SQL is ever built from data. A Db is used by one thread at a time, with
// its statements.
//
// Compiled statements are reused: a Stmt that ends goes back to its Db reset
// and unbound (a few per SQL text), and Prepare of the same text takes it
// again instead of compiling it anew; what a statement does is the same
// either way (SQLite recompiles a reused one itself if the schema changed).
#ifndef IMUQUAL_STORE_SQLITE_H_
#define IMUQUAL_STORE_SQLITE_H_

#include <sqlite3.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace imuqual::store {

class Stmt;
class StatementCache;

class Db {
 public:
  enum class Mode { kReadWrite, kReadOnly };
  // Opens (kReadWrite: creating) the file. The file is not read until the
  // first statement; Archive::Open checks that it really is a database.
  static Result<std::unique_ptr<Db>> Open(const std::string& path, Mode mode);
  ~Db();
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;

  // Runs one or more statements without parameters (DDL, pragmas).
  Status Exec(const std::string& sql);
  // Compiles one statement (or reuses an idle one of the same text).
  Result<Stmt> Prepare(const std::string& sql);
  // Single integer result of a query such as "PRAGMA user_version".
  Result<int64_t> QueryInt(const std::string& sql);

  sqlite3* handle() { return db_; }
  const std::string& path() const { return path_; }
  // The last error as "<sqlite message> (<extended code name>)".
  std::string ErrorMessage() const;

 private:
  Db(sqlite3* db, std::string path);
  sqlite3* db_;
  std::string path_;
  // Idle statements; shared with the Stmts, which may outlive the Db (then
  // they are finalized when they end).
  std::shared_ptr<StatementCache> cache_;
};

// A prepared statement. Bind*() indices are 1-based, as in SQLite.
class Stmt {
 public:
  Stmt(Stmt&& other) noexcept;
  Stmt& operator=(Stmt&& other) noexcept;
  ~Stmt();

  Stmt& Bind(int i, int64_t v);
  Stmt& Bind(int i, int v) { return Bind(i, static_cast<int64_t>(v)); }
  Stmt& Bind(int i, double v);            // NaN binds NULL
  Stmt& Bind(int i, std::string_view v);  // text
  Stmt& Bind(int i, const char* v) { return Bind(i, std::string_view(v)); }
  Stmt& Bind(int i, const std::string& v) { return Bind(i, std::string_view(v)); }
  Stmt& BindBlob(int i, std::span<const uint8_t> v);
  Stmt& BindNull(int i);
  Stmt& Bind(int i, std::optional<double> v) { return v ? Bind(i, *v) : BindNull(i); }
  Stmt& Bind(int i, std::optional<int64_t> v) { return v ? Bind(i, *v) : BindNull(i); }
  Stmt& Bind(int i, const std::optional<std::string>& v) { return v ? Bind(i, *v) : BindNull(i); }

  // Steps once: true while a row is available, false when done.
  Result<bool> Step();
  // Steps to completion (for writes), then resets for reuse.
  Status Run();
  void Reset();

  // The compiled statement, for the C API's column functions (valid while
  // this Stmt lives; do not finalize it).
  sqlite3_stmt* handle() { return stmt_; }

  int64_t Int(int col) const;
  double Real(int col) const;  // NULL reads as NaN
  std::string Text(int col) const;
  std::vector<uint8_t> Blob(int col) const;
  bool IsNull(int col) const;

 private:
  friend class Db;
  Stmt(sqlite3_stmt* stmt, Db* db, std::string sql, std::shared_ptr<StatementCache> cache)
      : stmt_(stmt), db_(db), sql_(std::move(sql)), cache_(std::move(cache)) {}
  // Gives the statement back to the cache (or finalizes it).
  void Release();
  sqlite3_stmt* stmt_ = nullptr;
  Db* db_ = nullptr;
  std::string sql_;
  std::shared_ptr<StatementCache> cache_;
  Status bind_error_;
};

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_SQLITE_H_
