#include "common/seq_tracker.h"

#include <algorithm>

namespace imuqual {

SeqTracker::SeqTracker(int64_t next_seq, const Options& options)
    : options_(options), next_seq_(next_seq) {}

SeqTracker::Arrival SeqTracker::Offer(int64_t seq) {
  if (seq < 0 || seq > next_seq_ + options_.max_ahead) return Arrival::kAbsurd;
  if (seq < next_seq_ || ahead_.count(seq)) return Arrival::kDuplicate;
  if (seq == next_seq_) {
    ++next_seq_;
    Advance();
  } else {
    ahead_.insert(seq);
  }
  return Arrival::kNew;
}

void SeqTracker::Advance() {
  while (!ahead_.empty() && *ahead_.begin() == next_seq_) {
    ahead_.erase(ahead_.begin());
    ++next_seq_;
  }
}

void SeqTracker::SetAnnouncedLast(int64_t last_seq) {
  announced_last_ = std::max(announced_last_, last_seq);
}

std::vector<SeqRange> SeqTracker::Holes() const {
  std::vector<SeqRange> holes;
  int64_t from = next_seq_;
  for (int64_t s : ahead_) {
    if (s > from) holes.push_back({from, s - 1});
    from = s + 1;
  }
  if (announced_last_ >= from) holes.push_back({from, announced_last_});
  return holes;
}

// Keeps one state per current hole, keyed by its first seq. A hole with the
// same first seq is the same hole, unchanged; one that starts later than the
// hole it came from has shrunk (resent batches arrived): progress, so it is
// asked for again at once and its give-up clock restarts.
void SeqTracker::Refresh(double now_s) {
  std::map<int64_t, HoleState> next;
  for (const SeqRange& h : Holes()) {
    auto it = holes_.upper_bound(h.first);
    HoleState state{now_s, now_s + options_.first_request_delay_s, options_.first_request_delay_s};
    if (it != holes_.begin()) {
      --it;
      if (it->first == h.first) {
        state = it->second;
      } else if (it->second.requested) {
        state = HoleState{now_s, now_s, options_.first_request_delay_s};
      }
    }
    next[h.first] = state;
  }
  holes_ = std::move(next);
}

std::vector<SeqRange> SeqTracker::DueRequests(double now_s) {
  Refresh(now_s);
  std::vector<SeqRange> due;
  for (const SeqRange& h : Holes()) {
    HoleState& st = holes_[h.first];
    if (now_s >= st.next_request_s) {
      due.push_back({h.first, std::min(h.last, h.first + options_.max_request - 1)});
      st.requested = true;
      st.backoff_s = std::min(st.backoff_s * 2, options_.max_backoff_s);
      st.next_request_s = now_s + st.backoff_s;
    }
  }
  return due;
}

std::vector<SeqRange> SeqTracker::TakeGivenUp(double now_s) {
  Refresh(now_s);
  std::vector<SeqRange> given_up;
  // Only holes at the frontier can be given up in order; later ones wait
  // their turn (their age keeps counting).
  for (;;) {
    std::vector<SeqRange> holes = Holes();
    if (holes.empty() || holes.front().first != next_seq_) break;
    const HoleState& st = holes_[holes.front().first];
    if (now_s - st.first_seen_s < options_.give_up_after_s) break;
    given_up.push_back(holes.front());
    holes_.erase(holes.front().first);
    next_seq_ = holes.front().last + 1;
    Advance();
  }
  return given_up;
}

void SeqTracker::Postpone(double now_s) {
  Refresh(now_s);
  for (auto& [first, st] : holes_) {
    st = HoleState{now_s, now_s + options_.first_request_delay_s, options_.first_request_delay_s};
  }
}

void SeqTracker::Skip(const SeqRange& range) {
  for (int64_t s = std::max(range.first, next_seq_); s <= range.last; ++s) ahead_.insert(s);
  Advance();
}

std::vector<SeqRange> SeqTracker::GiveUpAll() {
  std::vector<SeqRange> holes = Holes();
  holes_.clear();
  ahead_.clear();
  next_seq_ = std::max(next_seq_, announced_last_ + 1);
  return holes;
}

}  // namespace imuqual
