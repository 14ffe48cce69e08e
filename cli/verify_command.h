// `imuqual verify --db FILE`: checks a whole archive for damage at rest:
// SQLite's PRAGMA integrity_check, then every stored checksum (each raw
// chunk, each run's result rows). One line per problem on stdout, naming the
// run and chunk; exit 0 when clean, 1 when anything is damaged (or the file
// cannot be read as an archive), 2 on a usage error.
#ifndef IMUQUAL_CLI_VERIFY_COMMAND_H_
#define IMUQUAL_CLI_VERIFY_COMMAND_H_

#include <string>

namespace imuqual::cli {

int VerifyCommand(const std::string& db_path);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_VERIFY_COMMAND_H_
