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

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_LOG_H_
