// The PostgreSQL side of store::Db and store::Stmt (store/sqlite.h): a
// libpq connection, and a statement run with its parameters as text (bytea
// in binary) and read back as text rows. Internal to store/.
#ifndef IMUQUAL_STORE_POSTGRES_H_
#define IMUQUAL_STORE_POSTGRES_H_

#include <libpq-fe.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace imuqual::store {

struct PgConnection {
  PGconn* conn = nullptr;
  int64_t changes = 0;  // rows of the last INSERT/UPDATE/DELETE
  // Statements prepared on the server, by SQL text (planned once: a sync
  // runs the same few statements for every run).
  std::map<std::string, std::string> prepared;
  ~PgConnection();
};

// Connects to `url` (a libpq URI). `read_only`: every transaction of the
// session is read only. `label` is the URL without its password.
Result<std::unique_ptr<PgConnection>> PgConnect(const std::string& url, bool read_only,
                                                std::string* label);

// SQLite's parameters (?N, ?) as PostgreSQL's ($N), outside quotes and
// comments.
std::string PgTranslate(std::string_view sql);

struct PgQuery {
  std::string sql;  // translated
  std::vector<std::optional<std::string>> values;
  std::vector<int> formats;  // 1: binary (bytea)
  std::vector<unsigned> types;
  PGresult* result = nullptr;
  int row = -1;
  ~PgQuery();
  void Set(int i, std::optional<std::string> value, bool binary);
  void Clear();  // the result and the parameters
};

// Runs the query the first time, then steps through its rows.
Result<bool> PgStep(PgConnection& c, PgQuery& q, const std::string& label);
// Runs statements without parameters.
Status PgExec(PgConnection& c, const std::string& sql, const std::string& label);

// The first line of the server's message.
std::string PgError(PGconn* conn);

}  // namespace imuqual::store

#endif  // IMUQUAL_STORE_POSTGRES_H_
