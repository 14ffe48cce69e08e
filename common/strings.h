// String splitting and joining, header-only so that the pure libraries can
// use them without the rest of common/.
#ifndef IMUQUAL_COMMON_STRINGS_H_
#define IMUQUAL_COMMON_STRINGS_H_

#include <algorithm>
#include <charconv>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace imuqual {

// "a,b,,c" -> {"a", "b", "", "c"}.
inline std::vector<std::string> Split(std::string_view text, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    const size_t pos = text.find(sep, start);
    parts.emplace_back(text.substr(start, pos - start));
    if (pos == std::string_view::npos) return parts;
    start = pos + 1;
  }
}

// {"a", "b", "c"} with ", " -> "a, b, c".
inline std::string Join(const std::vector<std::string>& parts, std::string_view sep) {
  std::string out;
  for (size_t i = 0; i < parts.size(); ++i) {
    if (i > 0) out += sep;
    out += parts[i];
  }
  return out;
}

// The shortest decimal text that reads back as exactly `v` (0.04, not
// %.17g's 0.040000000000000001): for CSV, JSON and every value written for
// programs. "nan", "inf", "-inf" for those (callers say what they want
// instead: an empty cell, null).
inline std::string ShortestReal(double v) {
  char buf[32];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, v);
  return r.ec == std::errc() ? std::string(buf, r.ptr) : std::string();
}

// The name of `known` closest to a mistyped `given` (edit distance, ties to
// the first), "" when none is close: at most 2 edits, and fewer than half
// the letters of `given`. For "unknown command 'lotz' (did you mean 'lot'?)".
inline std::string ClosestName(std::string_view given, const std::vector<std::string>& known) {
  std::string best;
  const size_t allowed = given.empty() ? 0 : std::min<size_t>(2, (given.size() - 1) / 2);
  size_t best_distance = allowed + 1;
  for (const std::string& name : known) {
    // Levenshtein distance, one row at a time.
    std::vector<size_t> row(name.size() + 1);
    for (size_t j = 0; j <= name.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= given.size(); ++i) {
      size_t diagonal = row[0];
      row[0] = i;
      for (size_t j = 1; j <= name.size(); ++j) {
        const size_t above = row[j];
        row[j] = std::min(
            {row[j] + 1, row[j - 1] + 1, diagonal + (given[i - 1] == name[j - 1] ? 0 : 1)});
        diagonal = above;
      }
    }
    if (row[name.size()] < best_distance) {
      best_distance = row[name.size()];
      best = name;
    }
  }
  return best;
}

// " (did you mean X?)" with X the ClosestName of `given`, or "" when none
// is close.
inline std::string DidYouMean(std::string_view given, const std::vector<std::string>& known) {
  const std::string closest = ClosestName(given, known);
  return closest.empty() ? std::string() : " (did you mean " + closest + "?)";
}

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_STRINGS_H_
