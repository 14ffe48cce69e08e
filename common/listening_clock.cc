#include "common/listening_clock.h"

#include <algorithm>

#include "common/clock.h"

namespace imuqual {

double ListeningClock::Observe(double monotonic_s) {
  std::lock_guard<std::mutex> lock(mu_);
  if (!started_) {
    started_ = true;
    last_ = monotonic_s;
  }
  const double now = std::max(monotonic_s, last_);
  if (now - last_ > max_step_s_) paused_ += now - last_ - max_step_s_;
  last_ = now;
  return now - paused_;
}

double ListeningClock::paused_s() const {
  std::lock_guard<std::mutex> lock(mu_);
  return paused_;
}

namespace {
ListeningClock& ProcessClock() {
  static ListeningClock clock;
  return clock;
}
}  // namespace

double ListeningSeconds() { return ProcessClock().Observe(MonotonicSeconds()); }
double ListeningPausedSeconds() { return ProcessClock().paused_s(); }

}  // namespace imuqual
