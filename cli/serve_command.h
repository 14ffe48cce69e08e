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
  std::string token;                      // --token (a token is required beyond loopback)
  std::string token_file;                 // --token-file: the token's first line (not in `ps`)
  bool new_token = false;                 // --new-token: make one and write it to --token-file
  std::string bus_url;                    // --bus: a station bus for the live page
  BusSecurityFiles bus_security;          // its keys (--key-file, --trust, ...)
  std::string tls_cert;                   // --tls-cert: PEM certificate chain (HTTPS)
  std::string tls_key;                    // --tls-key: its PEM private key
  bool insecure_http = false;             // --insecure-http: plain HTTP beyond loopback
};

// Prints the URL, serves until interrupted. With --new-token, a new token
// (web/access.h NewToken) is written to --token-file (created 0600, never
// over an existing file) once the server could start, and the file is named
// (the token itself is printed nowhere). Returns 0 when stopped by a signal,
// 1 when it cannot serve (the archive, a port in use, the token file), 2 on
// a usage error (a bad --listen or token, a non-loopback address without a
// token or without TLS or --insecure-http, a bad certificate or key file).
int ServeCommand(const ServeCommandOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_SERVE_COMMAND_H_
