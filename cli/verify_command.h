// `imuqual verify --db FILE [--pubkey KEYS]... [--expect-head N:HEX]`: checks
// an archive for damage at rest (SQLite's PRAGMA integrity_check, every
// stored checksum) and for tampering (store/chain_verify.h): every run's
// signed record against what the archive holds now, the hash chain of
// finalised runs, and, with --pubkey (a store's .pub file or a trust file),
// every signature. One line per problem on stdout, naming the run or the
// chain entry and what broke; a summary on stderr (runs verified, unsigned
// with their ids, open, the chain's head).
// Exit: 0 clean (without --pubkey: signatures present but not checked, and
// it says so); 1 anything damaged or broken (or the file cannot be read as
// an archive); 2 a usage error; 3 with --pubkey, nothing broken but some
// finalised runs unsigned (archived before schema 7 or by a store without
// --sign-key): they are listed, never reported verified.
// `imuqual verify --db FILE --head` prints the chain's head "N:HEX" (after
// checking the chain's links), to keep outside the archive (a ticket, a
// WORM store) and give back later as --expect-head.
#ifndef IMUQUAL_CLI_VERIFY_COMMAND_H_
#define IMUQUAL_CLI_VERIFY_COMMAND_H_

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace imuqual::cli {

struct VerifyOptions {
  std::string db_path;
  std::vector<std::string> pubkey_paths;  // trusted public keys; none: not checked
  bool head = false;                      // print the chain head only
  std::string expect_head;                // "N:HEX" kept from an earlier --head
};

// Registers `verify` and its options on `app`; the options land in `o`.
CLI::App* AddVerifyCommand(CLI::App& app, VerifyOptions* o);

int VerifyCommand(const VerifyOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_VERIFY_COMMAND_H_
