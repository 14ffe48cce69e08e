#include "analyze/allan/curve.h"

#include <array>
#include <utility>

namespace imuqual::allan {
namespace {

// One table per enum keeps each name and its parser in step.
constexpr std::array<std::pair<Deviation, std::string_view>, 13> kDeviationNames = {{
    {Deviation::kAdev, "adev"},
    {Deviation::kOadev, "oadev"},
    {Deviation::kMdev, "mdev"},
    {Deviation::kTdev, "tdev"},
    {Deviation::kHdev, "hdev"},
    {Deviation::kOhdev, "ohdev"},
    {Deviation::kTotdev, "totdev"},
    {Deviation::kTheo1, "theo1"},
    {Deviation::kTheoBr, "theobr"},
    {Deviation::kTheoH, "theoh"},
    {Deviation::kMtotdev, "mtotdev"},
    {Deviation::kTtotdev, "ttotdev"},
    {Deviation::kHtotdev, "htotdev"},
}};

constexpr std::array<std::pair<StopRule, std::string_view>, 3> kStopRuleNames = {{
    {StopRule::kBins9, "bins9"},
    {StopRule::kStable32, "stable32"},
    {StopRule::kNone, "none"},
}};

constexpr std::array<std::pair<CiMethod, std::string_view>, 3> kCiMethodNames = {{
    {CiMethod::kNone, "none"},
    {CiMethod::kSimple, "simple"},
    {CiMethod::kChi2, "chi2"},
}};

template <typename Enum, size_t kSize>
std::string_view NameOf(const std::array<std::pair<Enum, std::string_view>, kSize>& table,
                        Enum value) {
  for (const auto& [e, name] : table) {
    if (e == value) return name;
  }
  return "unknown";
}

template <typename Enum, size_t kSize>
std::optional<Enum> ValueOf(const std::array<std::pair<Enum, std::string_view>, kSize>& table,
                            std::string_view name) {
  for (const auto& [e, n] : table) {
    if (n == name) return e;
  }
  return std::nullopt;
}

}  // namespace

std::string_view DeviationName(Deviation d) { return NameOf(kDeviationNames, d); }
std::optional<Deviation> ParseDeviation(std::string_view name) {
  return ValueOf(kDeviationNames, name);
}

std::string_view StopRuleName(StopRule s) { return NameOf(kStopRuleNames, s); }
std::optional<StopRule> ParseStopRule(std::string_view name) {
  return ValueOf(kStopRuleNames, name);
}

std::string_view CiMethodName(CiMethod c) { return NameOf(kCiMethodNames, c); }
std::optional<CiMethod> ParseCiMethod(std::string_view name) {
  return ValueOf(kCiMethodNames, name);
}

}  // namespace imuqual::allan
