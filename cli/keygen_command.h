// `imuqual keygen`: makes the keys of a station (common/keys.h).
//   imuqual keygen --out station.key               the station key (bus MACs)
//   imuqual keygen --role store --out store.key    a role's signing key pair:
//                                                  store.key (secret) and store.key.pub
// Secret key files are created readable by their owner only and never
// overwrite a file. Prints what it wrote and the key's id; exit 0, or 1 with
// one line naming what was wrong.
#ifndef IMUQUAL_CLI_KEYGEN_COMMAND_H_
#define IMUQUAL_CLI_KEYGEN_COMMAND_H_

#include <string>

namespace imuqual::cli {

struct KeygenOptions {
  std::string out;   // key file to create
  std::string role;  // "": the station key; else acquire, analyze or store
};

int KeygenCommand(const KeygenOptions& options);

}  // namespace imuqual::cli

#endif  // IMUQUAL_CLI_KEYGEN_COMMAND_H_
