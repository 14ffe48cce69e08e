// Small text helpers shared by the processes and the CLI.
#ifndef IMUQUAL_COMMON_TEXT_UTIL_H_
#define IMUQUAL_COMMON_TEXT_UTIL_H_

#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "common/strings.h"

namespace imuqual {

// Whole file as a string; the error names the file and the OS reason.
Result<std::string> ReadFileToString(const std::string& path);
// Writes atomically (temp file + rename); the error names the file.
Status WriteStringToFile(const std::string& path, std::string_view data);

// Lower-case hex SHA-256 of `data`.
std::string Sha256Hex(std::string_view data);

// A serial number or other identifier that is safe in LCM channel names and
// file names: 1-48 of [A-Za-z0-9._-]. The error names `what`.
Status ValidateIdentifier(std::string_view what, std::string_view value);

// ClosestName (did you mean ...?) lives in common/strings.h.

// Whether a name is missing: empty or only blanks (an operator "  " is none).
inline bool IsBlank(std::string_view name) {
  return name.find_first_not_of(" \t") == std::string_view::npos;
}

// Natural order of names such as fixture slots: runs of digits compare as
// numbers ("2" before "10", "A2" before "A10"; "A02" and "A2" are equal),
// the rest byte by byte. A strict weak order.
bool NaturalLess(const std::string& a, const std::string& b);

// Text for HTML or SVG (XML) element content or a quoted attribute value:
// & < > " ' escaped.
std::string HtmlEscape(std::string_view s);

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_TEXT_UTIL_H_
