// `imuqual sync`: ships a station's archive to the plant archive
// (store/plant_sync.h).
//   imuqual sync --db station.db --to postgresql://... [--pubkey store.key.pub]
// Prints what it shipped; exit 0 (everything shipped, or nothing new), 1
// the plant or the station could not be read or written (what was shipped
// before stays: run it again), 2 usage, 3 an entry or run was refused (named
// on stderr; everything before it is shipped).
#ifndef IMUQUAL_CLI_SYNC_COMMAND_H_
#define IMUQUAL_CLI_SYNC_COMMAND_H_

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace imuqual::cli {

struct SyncOptions {
  std::string db_path;  // the station's archive file
  std::string to;       // postgresql://...
  std::vector<std::string> pubkey_paths;
  bool allow_unsigned = false;
  int batch = 32;
  std::string new_archive_of;  // a station id this archive takes over
  bool quiet = false;
};

CLI::App* AddSyncCommand(CLI::App& app, SyncOptions* options);
int SyncCommand(const SyncOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_SYNC_COMMAND_H_
