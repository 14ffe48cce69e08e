#include "cli/serve_command.h"

#include <sys/stat.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "common/exit_codes.h"
#include "common/log.h"
#include "common/shutdown.h"
#include "common/text_util.h"
#include "web/access.h"
#include "web/web_server.h"

namespace imuqual::cli {

int ServeCommand(const ServeCommandOptions& options) {
  web::ServeOptions o;
  o.db_path = options.db_path;
  o.token = options.token;
  o.bus_url = options.bus_url;
  if (!o.bus_url.empty()) {
    auto security = options.bus_security.Load(BusRole::kMonitor);
    if (!security.ok()) {
      LogError("serve: " + security.status().message());
      return kExitUsage;
    }
    o.bus_security = std::move(*security);
  }
  o.tls_cert_path = options.tls_cert;
  o.tls_key_path = options.tls_key;
  o.insecure_http = options.insecure_http;
  if (options.new_token) {
    if (options.token_file.empty()) {
      LogError("serve: --new-token needs --token-file FILE (where the new token is written)");
      return kExitUsage;
    }
    if (!options.token.empty()) {
      LogError("serve: give --new-token or --token, not both");
      return kExitUsage;
    }
    struct stat info {};
    if (::stat(options.token_file.c_str(), &info) == 0) {
      LogError("serve: --new-token: " + options.token_file +
               " exists already (a token file is never overwritten: remove it, or serve with it "
               "without --new-token)");
      return kExitUsage;
    }
    auto token = web::NewToken();
    if (!token.ok()) {
      LogError(token.status().message());
      return kExitError;
    }
    o.token = *token;
  } else if (!options.token_file.empty()) {
    if (!options.token.empty()) {
      LogError("serve: give --token or --token-file, not both");
      return kExitUsage;
    }
    auto text = ReadFileToString(options.token_file);
    if (!text.ok()) {
      LogError("serve: --token-file: " + text.status().message());
      return kExitUsage;
    }
    o.token = text->substr(0, text->find_first_of("\r\n"));
  }
  Status st = web::ParseListen(options.listen, &o);
  if (!st.ok()) {
    LogError(st.message());
    return kExitUsage;
  }
  auto server = web::WebServer::Start(o);
  if (!server.ok()) {
    LogError(server.status().message());
    return server.status().code() == Status::Code::kInvalidArgument ? kExitUsage : kExitError;
  }
  if (options.new_token) {
    // Only once the server could start: a failed start leaves no file behind.
    st = web::WriteNewTokenFile(options.token_file, o.token);
    if (!st.ok()) {
      LogError(st.message());
      return kExitError;
    }
  }
  InstallShutdownHandlers();
  const bool v6 = o.host.find(':') != std::string::npos;
  const std::string base = std::string((*server)->tls() ? "https" : "http") + "://" +
                           (v6 ? "[" : "") + o.host + (v6 ? "]" : "") + ":" +
                           std::to_string((*server)->port()) + "/";
  std::printf("serving %s at %s%s (read-only; Ctrl-C stops)\n", o.db_path.c_str(), base.c_str(),
              o.token.empty() ? "" : "?token=...");
  if (options.new_token) {
    std::printf(
        "a new token is in %s (owner-only): open %s?token= followed by it, once (the "
        "browser keeps it in a cookie)\n",
        options.token_file.c_str(), base.c_str());
  }
  if (!o.bus_url.empty())
    std::printf("live station (bus %s): %slive\n", o.bus_url.c_str(), base.c_str());
  if (!web::IsLoopback(o.host)) {
    std::printf("listening beyond this host: every request needs the token%s\n",
                (*server)->tls() ? ""
                                 : "; plain HTTP (--insecure-http): the token crosses the "
                                   "network in clear");
  }
  std::fflush(stdout);
  std::thread serving([&] { (*server)->Run(); });
  while (!ShutdownRequested()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  (*server)->Stop();
  serving.join();
  return kExitOk;
}

}  // namespace imuqual::cli
