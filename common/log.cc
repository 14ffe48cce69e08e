#include "common/log.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <mutex>

#include "common/clock.h"

namespace imuqual {
namespace {

std::mutex& NameMutex() {
  static std::mutex mu;
  return mu;
}
std::string& ProgramName() {
  static std::string name = "imuqual";
  return name;
}
std::atomic<bool> g_quiet{false};

void Write(const char* level, const std::string& message) {
  std::string prefix;
  {
    std::lock_guard<std::mutex> lock(NameMutex());
    prefix = ProgramName();
  }
  prefix += ": ";
  if (level[0] != '\0') {
    prefix += level;
    prefix += ": ";
  }
  // A message of several problems (a plan's every mistake) is one line per
  // problem, each with the prefix, so that every line says whose it is.
  std::string line;
  for (size_t at = 0; at == 0 || at < message.size();) {  // a trailing newline adds no line
    const size_t end = std::min(message.find('\n', at), message.size());
    line += prefix;
    line.append(message, at, end - at);
    line += '\n';
    at = end + 1;
  }
  // One write() per line keeps lines from different threads whole.
  ssize_t ignored = ::write(STDERR_FILENO, line.data(), line.size());
  (void)ignored;
}

}  // namespace

void SetLogProgramName(const std::string& name) {
  std::lock_guard<std::mutex> lock(NameMutex());
  ProgramName() = name;
}
void SetLogQuiet(bool quiet) { g_quiet = quiet; }

void LogInfo(const std::string& message) {
  if (!g_quiet) Write("", message);
}
void LogWarning(const std::string& message) { Write("warning", message); }
void LogError(const std::string& message) { Write("error", message); }

void ThrottledLog::Error(const std::string& message) { Emit("error", message); }
void ThrottledLog::Warning(const std::string& message) { Emit("warning", message); }

void ThrottledLog::Emit(const char* level, const std::string& message) {
  const double now = MonotonicSeconds();
  if (now - last_s_ < period_s_) {
    ++suppressed_;
    return;
  }
  Write(level, suppressed_ > 0 ? message + " (and " + std::to_string(suppressed_) +
                                     " more like it since the last report)"
                               : message);
  last_s_ = now;
  suppressed_ = 0;
}

}  // namespace imuqual
