// Process shutdown on SIGINT/SIGTERM: the signal handler only sets a flag;
// service loops poll ShutdownRequested() between bounded waits, then drain
// and join their workers (the lcm-logger pattern).
#ifndef IMUQUAL_COMMON_SHUTDOWN_H_
#define IMUQUAL_COMMON_SHUTDOWN_H_

namespace imuqual {

// run_t.end_reason of a run aborted because the operator stopped the
// station (Ctrl-C, a hang-up, SIGTERM). An aborted run with any other end
// reason was ended by a failure (its source, or the station): the analysis
// tells the two apart by this reason (verdict ABORTED, else ERROR).
inline constexpr char kShutdownEndReason[] = "shutdown requested";

// Installs the handlers (idempotent). SIGPIPE is ignored.
void InstallShutdownHandlers();
bool ShutdownRequested();
// Sets the flag from inside the process (tests, fatal errors).
void RequestShutdown();
// Clears the flag (tests that run several services in one process).
void ResetShutdownForTest();

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_SHUTDOWN_H_
