// The command-line flags of a bus connection's keys and choices, the same in
// every process (README, "Trust").
#ifndef IMUQUAL_COMMON_BUS_FLAGS_H_
#define IMUQUAL_COMMON_BUS_FLAGS_H_

#include <CLI/CLI.hpp>

#include "common/bus_seal.h"

namespace imuqual {

// Adds --key-file, --sign-key (when the process has a role that signs),
// --trust, --insecure-bus, --max-message-age and, for processes that take
// recorded traffic (`replays`), --accept-replay.
inline void AddBusSecurityFlags(CLI::App& app, BusSecurityFiles* files, bool signs, bool replays) {
  app.add_option("--key-file", files->key_file,
                 "the station key (imuqual keygen): a MAC on every message; a bus beyond this "
                 "host (ttl > 0) needs it")
      ->check(CLI::ExistingFile);
  if (signs) {
    app.add_option("--sign-key", files->sign_key,
                   "this process's role signing key (imuqual keygen --role ROLE): signs its "
                   "verdict-bearing messages")
        ->check(CLI::ExistingFile);
  }
  app.add_option("--trust", files->trust_file,
                 "the roles' public keys (their .pub files in one file): run announcements, "
                 "curves, results, decisions and archive acknowledgements must be signed by "
                 "their role's key")
      ->check(CLI::ExistingFile);
  app.add_flag("--insecure-bus", files->insecure_bus,
               "run on a bus beyond this host without a station key: nothing on it is "
               "authenticated (every archived run records it)");
  app.add_option("--max-message-age", files->max_age_s,
                 "seconds a message may be old (or the hosts' clocks apart) and still be taken; "
                 "older ones are refused as replayed")
      ->capture_default_str();
  if (replays) {
    app.add_flag("--accept-replay", files->accept_replay,
                 "take messages older than that: a recorded station log played back on purpose "
                 "(every run archived records it); a message is still taken once");
  }
}

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_BUS_FLAGS_H_
