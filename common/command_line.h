// Exit codes shared by every imuqual binary, and the command-line parse that
// uses them (README, "Exit codes").
#ifndef IMUQUAL_COMMON_COMMAND_LINE_H_
#define IMUQUAL_COMMON_COMMAND_LINE_H_

#include <optional>

#include <CLI/CLI.hpp>

namespace imuqual {

inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 1;   // data, archive, device or process failure
inline constexpr int kExitUsage = 2;   // the command line or a configuration file is wrong

// Parses the command line. --help and --version print and give kExitOk; any
// other parse error prints its one-line message and gives kExitUsage (not
// CLI11's own 105-115); nullopt: parsed, go on.
inline std::optional<int> ParseCommandLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitUsage;
  }
  return std::nullopt;
}

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_COMMAND_LINE_H_
