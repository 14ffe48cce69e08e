// Fuzzes test-plan parsing and validation (protobuf text format).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "analyze/judge/judge.h"
#include "analyze/judge/plan.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > (1 << 16)) return 0;
  auto plan = imuqual::judge::ParsePlanText(
      std::string_view(reinterpret_cast<const char*>(data), size), "fuzz");
  if (!plan.ok()) {
    if (plan.status().message().rfind("fuzz:", 0) != 0) __builtin_trap();  // errors name the source
    return 0;
  }
  // A valid plan judges any measurements without failing.
  std::vector<imuqual::pb::Measurement> ms(2);
  ms[0].set_axis("x");
  ms[0].set_name("bias_instability");
  ms[0].set_value(12.0);
  ms[1].set_name("duration");
  ms[1].set_value(100.0);
  std::vector<imuqual::judge::AxisDesc> axes;
  for (const auto& a : plan->axes()) axes.push_back({a.name(), a.kind()});
  (void)imuqual::judge::Judge(*plan, axes, &ms);
  return 0;
}
