// Helpers for tests that drive the station's executables.
#ifndef IMUQUAL_TESTS_TEST_UTIL_H_
#define IMUQUAL_TESTS_TEST_UTIL_H_

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace imuqual::testing {

// True in an AddressSanitizer build (GCC says so with __SANITIZE_ADDRESS__,
// Clang with __has_feature): a Monte Carlo case there runs a few records
// for the memory checks and leaves its rates to the Release pass, which
// asserts them on every record.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kUnderSanitizers = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kUnderSanitizers = true;
#else
inline constexpr bool kUnderSanitizers = false;
#endif
#else
inline constexpr bool kUnderSanitizers = false;
#endif

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout (stderr goes to the test log)
};

// Runs a shell command line and captures its stdout.
inline CommandResult RunCommand(const std::string& command) {
  CommandResult r;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) r.output.append(buf.data(), n);
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

// A fresh directory under the system temp dir, removed by the destructor.
class TempDir {
 public:
  explicit TempDir(const std::string& tag) {
    path_ = std::filesystem::temp_directory_path() /
            ("imuqual_" + tag + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;  // never throw from a destructor
    std::filesystem::remove_all(path_, ignored);
  }
  std::string path(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

inline std::string Bin(const std::string& name) { return std::string(IMUQUAL_BIN_DIR) + "/" + name; }

}  // namespace imuqual::testing

#endif  // IMUQUAL_TESTS_TEST_UTIL_H_
