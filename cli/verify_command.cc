#include "cli/verify_command.h"

#include <cstdio>

#include "common/log.h"
#include "store/archive.h"
#include "store/checksums.h"

namespace imuqual::cli {

int VerifyCommand(const std::string& db_path) {
  auto archive = store::Archive::Open(db_path, store::Archive::Mode::kRead);
  if (!archive.ok()) {
    LogError(archive.status().message());
    return 1;
  }
  auto print = [](const std::string& line) { std::printf("%s\n", line.c_str()); };
  auto integrity = store::CheckIntegrity((*archive)->db(), print);
  if (!integrity.ok()) {
    LogError(integrity.status().message());
    return 1;
  }
  auto checksums = store::CheckChecksums((*archive)->db(), -1, print);
  if (!checksums.ok()) {
    // A file damaged enough stops the reading itself: that is a finding too.
    print("checksums: " + checksums.status().message());
    return 1;
  }
  const int64_t problems = *integrity + *checksums;
  if (problems > 0) {
    LogError(db_path + ": " + std::to_string(problems) + " problems");
    return 1;
  }
  std::fprintf(stderr, "%s: ok (integrity check and every checksum)\n", db_path.c_str());
  return 0;
}

}  // namespace imuqual::cli
