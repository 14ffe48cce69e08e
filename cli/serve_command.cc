#include "cli/serve_command.h"

#include <chrono>
#include <cstdio>
#include <thread>

#include "common/command_line.h"
#include "common/log.h"
#include "common/shutdown.h"
#include "common/text_util.h"
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
  if (!options.token_file.empty()) {
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
  InstallShutdownHandlers();
  const bool v6 = o.host.find(':') != std::string::npos;
  std::printf("serving %s at http://%s%s%s:%d/%s (read-only; Ctrl-C stops)\n", o.db_path.c_str(),
              v6 ? "[" : "", o.host.c_str(), v6 ? "]" : "", (*server)->port(),
              o.token.empty() ? "" : "?token=...");
  if (!o.bus_url.empty()) {
    std::printf("live station (bus %s): http://%s%s%s:%d/live\n", o.bus_url.c_str(), v6 ? "[" : "",
                o.host.c_str(), v6 ? "]" : "", (*server)->port());
  }
  if (!web::IsLoopback(o.host)) {
    std::printf("listening beyond this host: every request needs the token\n");
  }
  std::fflush(stdout);
  std::thread serving([&] { (*server)->Run(); });
  while (!ShutdownRequested()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  (*server)->Stop();
  serving.join();
  return kExitOk;
}

}  // namespace imuqual::cli
