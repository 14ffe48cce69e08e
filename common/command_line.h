// The command-line parse every imuqual binary uses, with the exit codes of
// common/exit_codes.h (README, "Exit codes").
#ifndef IMUQUAL_COMMON_COMMAND_LINE_H_
#define IMUQUAL_COMMON_COMMAND_LINE_H_

#include <CLI/CLI.hpp>
#include <cctype>
#include <optional>
#include <string>
#include <vector>

#include "common/exit_codes.h"
#include "common/log.h"
#include "common/status.h"
#include "common/text_util.h"

namespace imuqual {

// Parses the command line. --help and --version print and give kExitOk; any
// other parse error is one line "<program>: error: ..." and gives kExitUsage
// (not CLI11's own 105-115). An option the command does not have is named
// first, with the closest it has ("unknown option --dbb (did you mean
// --db?)"), not the required option it then seemed to leave out.
// nullopt: parsed, go on.
inline std::optional<int> ParseCommandLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) {
      return app.exit(e) == 0 ? kExitOk : kExitUsage;  // --help, --version
    }
    // The deepest command given, and the options it knows.
    CLI::App* command = &app;
    while (!command->get_subcommands().empty()) command = command->get_subcommands().front();
    std::vector<std::string> known;
    for (const CLI::Option* o : command->get_options()) {
      for (const std::string& n : o->get_lnames()) known.push_back("--" + n);
      for (const std::string& n : o->get_snames()) known.push_back("-" + n);
    }
    std::string message = e.what();
    for (const std::string& extra : app.remaining(true)) {
      if (extra.size() < 2 || extra[0] != '-' || std::isdigit(static_cast<unsigned char>(extra[1]))) {
        continue;  // a value, or a negative number
      }
      const std::string name = extra.substr(0, extra.find('='));
      message = "unknown option " + name;
      if (const std::string close = ClosestName(name, known); !close.empty()) {
        message += " (did you mean " + close + "?)";
      }
      break;
    }
    std::string program = app.get_name();  // argv[0] when the app has no name
    program = program.substr(program.find_last_of('/') + 1);
    const std::string path = command == &app ? "" : " " + command->get_name();
    LogError(message + " (" + program + path + " --help lists the options)");
    return kExitUsage;
  }
  return std::nullopt;
}

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_COMMAND_LINE_H_
