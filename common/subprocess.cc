#include "common/subprocess.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include "common/clock.h"

namespace imuqual {
namespace {

int ExitCode(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

}  // namespace

Result<Subprocess> Subprocess::Start(const std::vector<std::string>& argv,
                                     const std::string& log_path) {
  if (argv.empty()) return Status::InvalidArgument("no program to start");
  if (::access(argv[0].c_str(), X_OK) != 0) {
    return Status::NotFound("cannot run " + argv[0] + ": " + std::strerror(errno));
  }
  const int log_fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log_fd < 0) return Status::IoError("cannot open log " + log_path + ": " + std::strerror(errno));
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(log_fd);
    return Status::IoError(std::string("fork: ") + std::strerror(errno));
  }
  if (pid == 0) {
    // Child: own process group, die with the parent, output to the log.
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(127);  // the parent died before prctl
    ::dup2(log_fd, STDOUT_FILENO);
    ::dup2(log_fd, STDERR_FILENO);
    const int devnull = ::open("/dev/null", O_RDONLY);
    if (devnull >= 0) ::dup2(devnull, STDIN_FILENO);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::signal(SIGPIPE, SIG_DFL);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(log_fd);
  ::setpgid(pid, pid);  // also from the parent: no race with the child's own call
  Subprocess p;
  p.pid_ = pid;
  p.name_ = argv[0].substr(argv[0].find_last_of('/') + 1);
  return p;
}

Subprocess::Subprocess(Subprocess&& other) noexcept
    : pid_(other.pid_), name_(std::move(other.name_)), exit_code_(other.exit_code_), cpu_s_(other.cpu_s_) {
  other.pid_ = -1;
}

Subprocess& Subprocess::operator=(Subprocess&& other) noexcept {
  if (this != &other) {
    if (pid_ > 0 && !exit_code_) Stop(0);
    pid_ = other.pid_;
    name_ = std::move(other.name_);
    exit_code_ = other.exit_code_;
    cpu_s_ = other.cpu_s_;
    other.pid_ = -1;
  }
  return *this;
}

Subprocess::~Subprocess() {
  if (pid_ > 0 && !exit_code_) Stop(0);
}

void Subprocess::Reaped(int status, const struct rusage& usage) {
  exit_code_ = ExitCode(status);
  cpu_s_ = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
           static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) * 1e-6;
}

std::optional<int> Subprocess::Poll() {
  if (exit_code_ || pid_ <= 0) return exit_code_;
  int status = 0;
  struct rusage usage {};
  const pid_t r = ::wait4(pid_, &status, WNOHANG, &usage);
  if (r == pid_) Reaped(status, usage);
  return exit_code_;
}

double Subprocess::CpuSeconds() const {
  if (exit_code_ || pid_ <= 0) return cpu_s_;
  // utime and stime, fields 14 and 15 of /proc/PID/stat, in clock ticks.
  std::ifstream stat("/proc/" + std::to_string(pid_) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return 0;
  const size_t close = line.rfind(')');  // the command name may hold spaces
  if (close == std::string::npos) return 0;
  std::istringstream rest(line.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i >= 14) ticks += std::stod(field);
  }
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

void Subprocess::Signal(int sig) {
  if (pid_ > 0 && !Poll()) ::kill(pid_, sig);
}

std::optional<int> Subprocess::Wait(double timeout_s) {
  const double deadline = MonotonicSeconds() + timeout_s;
  for (;;) {
    if (Poll()) return exit_code_;
    if (MonotonicSeconds() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

int Subprocess::Stop(double timeout_s) {
  if (pid_ <= 0) return -1;
  if (Poll()) return *exit_code_;
  ::kill(pid_, SIGTERM);
  if (Wait(timeout_s)) return *exit_code_;
  ::kill(pid_, SIGKILL);
  int status = 0;
  struct rusage usage {};
  ::wait4(pid_, &status, 0, &usage);
  Reaped(status, usage);
  return *exit_code_;
}

std::string ExecutableDir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return ".";
  std::string path(buf, static_cast<size_t>(n));
  return path.substr(0, path.find_last_of('/'));
}

}  // namespace imuqual
