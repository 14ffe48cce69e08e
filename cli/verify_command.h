// `imuqual verify --db FILE [--pubkey KEYS]... [--expect-head N:HEX]`: checks
// an archive for damage at rest (SQLite's PRAGMA integrity_check, every
// stored checksum) and for tampering (store/chain_verify.h): every run's
// signed record against what the archive holds now, the hash chain of
// finalised runs, and, with --pubkey (a store's .pub file or a trust file),
// every signature. One line per problem on stdout, naming the run or the
// chain entry and what broke; a summary on stderr (runs verified, unsigned
// with their ids, open, the chain's head).
// With --pubkey, signatures are required: a chain entry without one (after
// the migration's) is broken, unless --allow-unsigned (a station that ran
// without a signing key on purpose): an attacker without the key can
// rebuild the chain unsigned, and that must not read as a configuration.
// Views and triggers must be this version's (an edited view changes every
// lot answer without touching a row).
// Exit: 0 clean (without --pubkey: signatures present but not checked, and
// it says so); 1 anything damaged or broken (or the file cannot be read as
// an archive); 2 a usage error; 3 with --pubkey, nothing broken but not all
// verified: runs archived before schema 7 (or, with --allow-unsigned, by a
// store without --sign-key), or runs not finalised that carry a verdict (a
// store still writing them, or rows written behind its back): listed,
// never reported verified.
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
  bool allow_unsigned = false;            // with --pubkey: unsigned entries are not broken
};

// Registers `verify` and its options on `app`; the options land in `o`.
CLI::App* AddVerifyCommand(CLI::App& app, VerifyOptions* o);

int VerifyCommand(const VerifyOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_VERIFY_COMMAND_H_
