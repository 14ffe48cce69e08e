// Child processes of a station launcher. Each child gets its own process
// group (a terminal's Ctrl-C reaches only the launcher, which stops the
// children in order) and dies with the launcher (PR_SET_PDEATHSIG), so a
// kill -9 of the launcher leaves no orphans. Output goes to a log file.
#ifndef IMUQUAL_COMMON_SUBPROCESS_H_
#define IMUQUAL_COMMON_SUBPROCESS_H_

#include <sys/resource.h>
#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include "common/status.h"

namespace imuqual {

class Subprocess {
 public:
  // Starts argv[0] (a path) with its stdout and stderr appended to log_path.
  static Result<Subprocess> Start(const std::vector<std::string>& argv, const std::string& log_path);
  Subprocess(Subprocess&& other) noexcept;
  Subprocess& operator=(Subprocess&& other) noexcept;
  ~Subprocess();  // kills (SIGKILL) and reaps a child still running

  pid_t pid() const { return pid_; }
  const std::string& name() const { return name_; }
  // Non-blocking: the exit status once the child has ended (reaped).
  std::optional<int> Poll();
  // Waits up to timeout_s for the child to end by itself; its exit code, or
  // nullopt if it is still running.
  std::optional<int> Wait(double timeout_s);
  // SIGTERM, then waits up to timeout_s; SIGKILL if still running. Returns
  // the exit code (128 + signal for a signal).
  int Stop(double timeout_s);
  void Signal(int sig);
  // CPU seconds (user + system) the child used: final once it has ended,
  // else so far (from /proc).
  double CpuSeconds() const;

 private:
  Subprocess() = default;
  void Reaped(int status, const struct rusage& usage);
  pid_t pid_ = -1;
  std::string name_;
  std::optional<int> exit_code_;
  double cpu_s_ = 0;
};

// Directory holding the running executable (/proc/self/exe), to find the
// sibling binaries.
std::string ExecutableDir();

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_SUBPROCESS_H_
