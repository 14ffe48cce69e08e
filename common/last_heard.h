// When each key (a run) was last heard on the bus, noted by the LCM handler
// thread as messages arrive and read by the worker. Staleness judged from
// dequeue times would mistake a worker's backlog for a silent source. Times
// are the process's listening clock (listening_clock.h): a process that was
// frozen does not find everyone silent when it wakes. Thread-safe.
#ifndef IMUQUAL_COMMON_LAST_HEARD_H_
#define IMUQUAL_COMMON_LAST_HEARD_H_

#include <limits>
#include <map>
#include <mutex>
#include <string>

#include "common/listening_clock.h"

namespace imuqual {

class LastHeard {
 public:
  void Note(const std::string& key) {
    const double now = ListeningSeconds();
    std::lock_guard<std::mutex> lock(mu_);
    heard_[key] = now;
  }
  // Listening seconds since `key` was last noted (`now_s` from
  // ListeningSeconds()); +infinity if never.
  double SecondsSince(const std::string& key, double now_s) const {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = heard_.find(key);
    return it == heard_.end() ? std::numeric_limits<double>::infinity() : now_s - it->second;
  }
  void Forget(const std::string& key) {
    std::lock_guard<std::mutex> lock(mu_);
    heard_.erase(key);
  }

 private:
  mutable std::mutex mu_;
  std::map<std::string, double> heard_;
};

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_LAST_HEARD_H_
