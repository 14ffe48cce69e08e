// Sequence tracking for one run on the receiving side (store, analyze).
// Batches arrive duplicated, out of order or not at all; the tracker keeps
// the contiguous frontier (every seq below next_seq() is handled), finds the
// holes (interior, and at the tail once the run's last seq is announced),
// schedules resend requests with exponential back-off, and gives a hole up
// after a deadline so the run can finish with the hole recorded as a gap.
// Time is passed in (monotonic seconds), so the logic is testable.
// Not thread-safe: one owner thread.
#ifndef IMUQUAL_COMMON_SEQ_TRACKER_H_
#define IMUQUAL_COMMON_SEQ_TRACKER_H_

#include <cstddef>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

namespace imuqual {

struct SeqRange {
  int64_t first = 0;
  int64_t last = 0;  // inclusive
  bool operator==(const SeqRange&) const = default;
};

class SeqTracker {
 public:
  struct Options {
    double first_request_delay_s = 0.05;  // a hole younger than this may still fill by itself
    double max_backoff_s = 4.0;          // request interval doubles up to this
    double give_up_after_s = 30.0;       // no progress on a hole this long: it becomes a gap
    int64_t max_ahead = 1 << 16;         // seqs accepted beyond next_seq(); further is absurd
    int64_t max_request = 256;           // seqs asked for per request (a resend is a burst)
  };

  explicit SeqTracker(int64_t next_seq = 0) : SeqTracker(next_seq, Options{}) {}
  SeqTracker(int64_t next_seq, const Options& options);

  enum class Arrival { kNew, kDuplicate, kAbsurd };
  // Records that `seq` arrived. kAbsurd: negative or beyond max_ahead; the
  // caller drops the batch (and counts it).
  Arrival Offer(int64_t seq);

  // The run's highest seq as announced (grows while the run runs).
  void SetAnnouncedLast(int64_t last_seq);
  // The run will not grow beyond its announced last seq (false: it may, after
  // all: a run believed ended was heard running again).
  void SetFinal(bool final = true) { final_ = final; }

  // Ranges to (re)request now: the front of each due hole, at most
  // max_request seqs. A hole that shrinks (part of it arrived) is making
  // progress: its back-off and its give-up clock start again.
  std::vector<SeqRange> DueRequests(double now_s);
  // Holes without progress for give_up_after_s: the frontier moves over them;
  // the caller records them as gaps. Returned in ascending order.
  std::vector<SeqRange> TakeGivenUp(double now_s);

  // Every hole up to the announced last seq becomes a gap now (the source is
  // gone: nothing more can be resent). Returned in ascending order.
  std::vector<SeqRange> GiveUpAll();
  // The receiver cannot take batches now (its archive fails to write): every
  // hole waits, its requests and its give-up clock start again from now.
  void Postpone(double now_s);
  // Treats a range as handled without it arriving (a gap recorded earlier,
  // e.g. by a store before it restarted).
  void Skip(const SeqRange& range);
  // Whether `seq` has arrived (or been skipped).
  bool Has(int64_t seq) const { return seq < next_seq_ || ahead_.count(seq) > 0; }

  int64_t next_seq() const { return next_seq_; }
  int64_t announced_last() const { return announced_last_; }
  // Every seq up to the final announced last seq was handled or given up.
  bool complete() const { return final_ && next_seq_ > announced_last_; }
  // Seqs received beyond the frontier (held out of order).
  size_t ahead() const { return ahead_.size(); }
  // The highest seq received or handled (-1 before any).
  int64_t highest() const { return ahead_.empty() ? next_seq_ - 1 : *ahead_.rbegin(); }

 private:
  struct HoleState {
    double first_seen_s;    // or the last progress
    double next_request_s;
    double backoff_s;
    bool requested = false;
  };
  void Advance();
  std::vector<SeqRange> Holes() const;
  void Refresh(double now_s);

  Options options_;
  int64_t next_seq_;
  int64_t announced_last_ = -1;
  bool final_ = false;
  std::set<int64_t> ahead_;             // received, > next_seq_
  std::map<int64_t, HoleState> holes_;  // keyed by the hole's first seq
};

}  // namespace imuqual

#endif  // IMUQUAL_COMMON_SEQ_TRACKER_H_
