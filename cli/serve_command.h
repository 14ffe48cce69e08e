// `imuqual serve`: the archive in a browser (web/web_server.h) until Ctrl-C
// or SIGTERM.
#ifndef IMUQUAL_CLI_SERVE_COMMAND_H_
#define IMUQUAL_CLI_SERVE_COMMAND_H_

#include <string>

#include "common/bus_seal.h"

namespace imuqual::cli {

struct ServeCommandOptions {
  std::string db_path;                    // --db (required)
  std::string listen = "127.0.0.1:8080";  // --listen ADDR:PORT
  std::string token;                      // --token (required beyond loopback)
  std::string token_file;                 // --token-file: the token's first line (not in `ps`)
  std::string bus_url;                    // --bus: a station bus for the live page
  BusSecurityFiles bus_security;          // its keys (--key-file, --trust, ...)
};

// Prints the URL, serves until interrupted. Returns 0 when stopped by a
// signal, 1 when it cannot serve (the archive, the address), 2 on a usage
// error (a bad --listen, a non-loopback address without --token).
int ServeCommand(const ServeCommandOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_SERVE_COMMAND_H_
