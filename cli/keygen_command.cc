#include "cli/keygen_command.h"

#include <iostream>

#include "common/keys.h"
#include "common/log.h"

namespace imuqual::cli {

int KeygenCommand(const KeygenOptions& options) {
  if (options.role.empty()) {
    auto key = GenerateStationKey();
    Status st = key.ok() ? WriteStationKeyFile(options.out, *key) : key.status();
    if (!st.ok()) {
      LogError(st.message());
      return 1;
    }
    std::cout << "station key " << key->Id() << " written to " << options.out
              << " (mode 0600): give it to every process of the station (--key-file, or key_file "
                 "in the station file)\n";
    return 0;
  }
  auto key = GenerateSigningKey(options.role);
  Status st = key.ok() ? WriteSigningKeyFiles(options.out, *key) : key.status();
  if (!st.ok()) {
    LogError(st.message());
    return 1;
  }
  std::cout << options.role << " signing key written to " << options.out << " (mode 0600, for the "
            << options.role << " process only: --sign-key) and its public key "
            << key->Public().Id() << " to " << options.out
            << ".pub (for every process and for verify: concatenate the "
            << "roles' .pub files into the station's trust file)\n";
  return 0;
}

}  // namespace imuqual::cli
