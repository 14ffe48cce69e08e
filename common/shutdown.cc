#include "common/shutdown.h"

#include <csignal>

namespace imuqual {
namespace {

volatile std::sig_atomic_t g_shutdown = 0;

extern "C" void OnShutdownSignal(int) { g_shutdown = 1; }

}  // namespace

void InstallShutdownHandlers() {
  struct sigaction sa {};
  sa.sa_handler = OnShutdownSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  // A hang-up (a dropped SSH session, a closed terminal) stops the station
  // like Ctrl-C: runs aborted, archived and judged, nothing left running.
  sigaction(SIGHUP, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

bool ShutdownRequested() { return g_shutdown != 0; }
void RequestShutdown() { g_shutdown = 1; }
void ResetShutdownForTest() { g_shutdown = 0; }

}  // namespace imuqual
