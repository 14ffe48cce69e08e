#include "acquire/device_protocol.h"

#include <string>

namespace imuqual::acquire {
namespace {

// 0, 1, 2 for a name ending in x, y, z (either case); -1 otherwise.
int ComponentFromName(const std::string& name) {
  if (name.empty()) return -1;
  switch (name.back()) {
    case 'x':
    case 'X':
      return 0;
    case 'y':
    case 'Y':
      return 1;
    case 'z':
    case 'Z':
      return 2;
    default:
      return -1;
  }
}

}  // namespace

Result<std::vector<AxisComponent>> AssignTripleComponents(const std::vector<pb::Axis>& axes,
                                                          std::string_view protocol) {
  if (axes.empty()) return Status::InvalidArgument(std::string(protocol) + " protocol: no axes");
  std::vector<AxisComponent> out(axes.size());
  for (bool gyro : {true, false}) {
    std::vector<size_t> of_kind;
    for (size_t i = 0; i < axes.size(); ++i) {
      if ((axes[i].kind() != pb::ACCEL) == gyro) of_kind.push_back(i);
    }
    if (of_kind.size() > 3) {
      return Status::InvalidArgument(std::string(protocol) + " protocol: at most three " +
                                     (gyro ? "gyro" : "accelerometer") + " axes (x, y, z); axis '" +
                                     axes[of_kind[3]].name() + "' is one too many");
    }
    bool by_name = true;
    int seen = 0;
    for (size_t i : of_kind) {
      const int c = ComponentFromName(axes[i].name());
      if (c < 0 || (seen & (1 << c))) by_name = false;
      if (c >= 0) seen |= 1 << c;
    }
    int next = 0;
    for (size_t i : of_kind) {
      out[i] = {gyro, by_name ? ComponentFromName(axes[i].name()) : next++};
    }
  }
  return out;
}

}  // namespace imuqual::acquire
