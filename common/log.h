// Minimal process logging to stderr: "<program>: <level>: <message>".
// Thread-safe (one write per line).
#ifndef IMUQUAL_COMMON_LOG_H_
#define IMUQUAL_COMMON_LOG_H_

#include <string>

namespace imuqual {

// Sets the program name that prefixes every line (default "imuqual").
void SetLogProgramName(const std::string& name);
// Suppresses LogInfo lines (warnings and errors still print).
void SetLogQuiet(bool quiet);

void LogInfo(const std::string& message);
void LogWarning(const std::string& message);
void LogError(const std::string& message);

// For errors that repeat at a high rate (a full disk fails every
// transaction): logs the first occurrence, then at most one line per period
// saying how many were suppressed. Not thread-safe; one per call site.
class ThrottledLog {
 public:
  explicit ThrottledLog(double period_s = 5.0) : period_s_(period_s) {}
  void Error(const std::string& message);
  void Warning(const std::string& message);

 private:
  void Emit(const char* level, const std::string& message);
  double period_s_;
  double last_s_ = -1e300;
  long suppressed_ = 0;
};

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_LOG_H_
