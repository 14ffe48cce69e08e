// Time this process has been running and listening, for judging others'
// silence. A process that was frozen (SIGSTOP, Ctrl-Z, a paused VM, a swap
// storm) heard nothing while it was stopped; on waking, the monotonic clock
// says seconds have passed and every peer looks silent, although they kept
// publishing. The listening clock advances with the monotonic clock except
// across a step longer than `max_step_s` between two observations, which
// counts only `max_step_s`: silence is declared only after the receiver has
// itself been awake for the whole window, and a hole's give-up timer does not
// run while nobody could have repaired it.
//
// Observed from every loop of the process (the bus loop every 100 ms, the
// worker every few ms), so a step longer than max_step_s means no thread ran.
#ifndef IMUQUAL_COMMON_LISTENING_CLOCK_H_
#define IMUQUAL_COMMON_LISTENING_CLOCK_H_

#include <mutex>

namespace imuqual {

class ListeningClock {
 public:
  explicit ListeningClock(double max_step_s = 1.0) : max_step_s_(max_step_s) {}
  // Listening seconds at monotonic time `monotonic_s` (non-decreasing across
  // calls; an earlier time is taken as the latest seen). Thread-safe.
  double Observe(double monotonic_s);
  // Seconds not counted so far (pauses beyond max_step_s). Thread-safe.
  double paused_s() const;

 private:
  const double max_step_s_;
  mutable std::mutex mu_;
  bool started_ = false;
  double last_ = 0;
  double paused_ = 0;
};

// The process's listening clock at the monotonic clock's now.
double ListeningSeconds();
// Seconds this process spent stopped (as seen by ListeningSeconds).
double ListeningPausedSeconds();

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_LISTENING_CLOCK_H_
