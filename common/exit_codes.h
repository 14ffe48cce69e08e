// Exit codes shared by every imuqual binary (README, "Exit codes"), without
// the command-line parser (common/command_line.h), so code that only returns
// them does not compile it.
#ifndef IMUQUAL_COMMON_EXIT_CODES_H_
#define IMUQUAL_COMMON_EXIT_CODES_H_

#include "common/status.h"

namespace imuqual {

inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 1;  // data, archive, device or process failure
inline constexpr int kExitUsage = 2;  // the command line or a configuration file is wrong

// The exit code of a command whose input could not be opened or read: a
// file that is not there or not what it should be is bad input (2), like a
// bad option; anything else is a failure while working (1).
inline int ExitCodeOf(const Status& s) {
  return s.code() == Status::Code::kNotFound || s.code() == Status::Code::kInvalidArgument
             ? kExitUsage
             : kExitError;
}

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_EXIT_CODES_H_
