// Fuzzes the text/CSV series parser (imuqual analyze FILE, CSV replay).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "common/numeric_text.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto table = imuqual::ParseNumericText(text, "fuzz");
  if (table.ok()) {
    for (const auto& column : table->columns) {
      if (column.size() != table->rows()) __builtin_trap();  // rows must line up
    }
    (void)imuqual::ParseSeries(text, "fuzz", table->names.front());
  }
  (void)imuqual::ParseNumericText(text, "fuzz", {"x", "gyro_z"});
  return 0;
}
