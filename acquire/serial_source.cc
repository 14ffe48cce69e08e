#include "acquire/serial_source.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/clock.h"
#include "common/log.h"

namespace imuqual::acquire {
namespace {

constexpr size_t kReadBytes = 1 << 16;
constexpr int kPollMs = 100;
constexpr double kReopenEveryS = 0.2;
// How late a frame may reach us (USB and scheduler latency, a busy host:
// beyond this the kernel's buffers overflow and data is lost rather than
// late), and how much less right after a reconnect flushed the port.
constexpr double kMaxLatenessS = 2.0;
constexpr double kReconnectLatenessS = 0.3;
// How far ahead of the least-late arrival a frame may seem (the anchor's own
// uncertainty).
constexpr double kAheadSlackS = 0.1;
// The largest crystal error the timeline allows for, as a fraction.
constexpr double kMaxRateError = 0.05;
constexpr uint64_t kCounterMask = 0x3FFFFFFFFFFFFFFFULL;

std::string WithoutPrefix(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0 ? s.substr(prefix.size()) : s;
}

}  // namespace

SerialSource::SerialSource(SerialSourceOptions options, std::unique_ptr<FrameDecoder> decoder,
                           SerialPort port)
    : o_(std::move(options)), decoder_(std::move(decoder)), port_(std::move(port)) {}

Result<std::unique_ptr<SerialSource>> SerialSource::Open(SerialSourceOptions options,
                                                         std::unique_ptr<FrameDecoder> decoder) {
  const std::string where = "serial " + options.port.device;
  if (!(options.rate_hz > 0) || !std::isfinite(options.rate_hz)) {
    return Status::InvalidArgument(where + ": rate must be > 0 Hz");
  }
  if (!(options.duration_s > 0) || !std::isfinite(options.duration_s)) {
    return Status::InvalidArgument(where + ": duration must be > 0 s (how long to record)");
  }
  if (!(options.reconnect_timeout_s > 0)) {
    return Status::InvalidArgument(where + ": reconnect timeout must be > 0 s");
  }
  if (options.axes.empty()) return Status::InvalidArgument(where + ": no axes");
  if (!decoder) return Status::InvalidArgument(where + ": no protocol decoder");
  auto port = SerialPort::Open(options.port);
  if (!port.ok()) return port.status();
  std::unique_ptr<SerialSource> s(new SerialSource(std::move(options), std::move(decoder), std::move(*port)));
  s->info_.axes = s->o_.axes;
  s->info_.nominal_rate_hz = s->o_.rate_hz;
  s->info_.description = "serial:" + s->o_.port.device + ",protocol=" + s->o_.protocol +
                         ",baud=" + std::to_string(s->o_.port.baud);
  s->info_.paced_by_device = true;
  s->info_.planned_s = s->o_.duration_s;
  s->total_samples_ = std::max<int64_t>(1, std::llround(s->o_.duration_s * s->o_.rate_hz));
  s->queue_limit_ = std::max<int64_t>(1000, std::llround(s->o_.queue_limit_s * s->o_.rate_hz));
  s->origin_mono_s_ = MonotonicSeconds();
  s->origin_utime_ = NowUtime();
  s->reader_ = std::thread([p = s.get()] { p->ReaderLoop(); });
  return s;
}

SerialSource::~SerialSource() { Stop(); }

void SerialSource::Stop() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  if (reader_.joinable()) reader_.join();
  port_.reset();  // the reader's, and the reader has ended
}

// Wall-clock microseconds on the monotonic clock's scale: arrival times keep
// their spacing even if the wall clock is stepped during a run.
int64_t SerialSource::HostUtime(double mono_s) const {
  return origin_utime_ + std::llround((mono_s - origin_mono_s_) * 1e6);
}

void SerialSource::WaitStop(double seconds) {
  std::unique_lock<std::mutex> lock(mu_);
  stop_cv_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return stop_; });
}

void SerialSource::ReaderLoop() {
  std::vector<uint8_t> buf(kReadBytes);
  std::vector<DeviceFrame> frames;
  const std::string who = "serial " + o_.port.device;
  double trouble_since = MonotonicSeconds();  // last frame, or when the device went away
  std::string trouble = "no frames";          // why no frames are coming
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (stop_ || ended_) return;
    }
    const double now = MonotonicSeconds();
    if (now - trouble_since > o_.reconnect_timeout_s) {
      char seconds[32];
      std::snprintf(seconds, sizeof seconds, "%g", o_.reconnect_timeout_s);
      std::lock_guard<std::mutex> lock(mu_);
      std::string detail;
      if (counters_.skipped_bytes > 0 || counters_.bad_checksum > 0 || counters_.malformed > 0) {
        detail = " (" + std::to_string(counters_.skipped_bytes) + " bytes skipped, " +
                 std::to_string(counters_.bad_checksum) + " bad checksums, " +
                 std::to_string(counters_.malformed) + " malformed frames: wrong baud or protocol?)";
      }
      error_ = Status::Unavailable(who + ": " + trouble + " for more than " + seconds + " s" + detail);
      return;
    }
    if (!port_) {
      auto port = SerialPort::Open(o_.port);
      if (!port.ok()) {
        trouble = "device gone (" + WithoutPrefix(port.status().message(), who + ": ") + ")";
        WaitStop(kReopenEveryS);
        continue;
      }
      port_ = std::move(*port);
      decoder_->Reset();
      trouble = "no frames since reconnecting";
      LogInfo(who + ": reconnected");
      std::lock_guard<std::mutex> lock(mu_);
      ++counters_.reconnects;
      reconnected_ = true;
      continue;
    }
    auto n = port_->Read(buf.data(), buf.size(), kPollMs);
    if (!n.ok()) {
      if (n.status().code() != Status::Code::kUnavailable) {
        std::lock_guard<std::mutex> lock(mu_);
        error_ = n.status();
        return;
      }
      trouble = "device gone (" + WithoutPrefix(n.status().message(), who + ": ") + ")";
      LogWarning(who + ": " + trouble + "; reconnecting");
      port_.reset();
      std::lock_guard<std::mutex> lock(mu_);
      reconnecting_ = true;
      continue;
    }
    if (*n == 0) continue;
    const double mono = MonotonicSeconds();
    frames.clear();
    decoder_->Feed(buf.data(), *n, &frames);
    std::lock_guard<std::mutex> lock(mu_);
    for (const DeviceFrame& f : frames) Accept(f, mono, HostUtime(mono));
    const DecoderCounters& d = decoder_->counters();
    counters_.bad_checksum = d.bad_checksum;
    counters_.malformed = d.malformed;
    counters_.skipped_bytes = d.skipped_bytes;
    counters_.other_messages = d.other_messages;
    if (!frames.empty()) {
      trouble_since = mono;
      trouble = "no frames";
      reconnecting_ = false;
    }
  }
}

// Where a frame goes on the device timeline. The host clock predicts it:
// anchor_ is the least-late arrival seen (mono - counter / rate), so a frame
// arriving now with no delay would be sample (mono - anchor_) * rate, and a
// real one is at most the allowed lateness behind that. The device's own
// counter is placed at the candidate (its wraps) nearest the prediction; a
// counter no candidate of which fits (a device restart, a corrupt counter)
// is re-based on the prediction. Right after a reconnect the port was just
// flushed, so frames must be prompt: a restarted device whose new counter
// happens to look plausible after a long unplug is still caught.
void SerialSource::Accept(const DeviceFrame& f, double mono_s, int64_t utime) {
  if (ended_) return;
  const double rate = o_.rate_hz;
  const int bits = decoder_->counter_bits();
  int64_t counter = 0;
  if (!have_last_) {
    counter = f.counter ? static_cast<int64_t>(*f.counter & kCounterMask) : 0;
    counter_offset_ = 0;
    anchor_s_ = mono_s - static_cast<double>(counter) / rate;
  } else {
    if (f.counter && *f.counter == last_raw_) {
      ++counters_.duplicate_frames;
      return;
    }
    const double since_s = mono_s - last_mono_s_;
    const double predicted = (mono_s - anchor_s_) * rate;
    // The device's clock may drift from nominal by up to kMaxRateError over
    // the time since the last frame; frames are late by up to the lateness.
    const double drift = kMaxRateError * since_s * rate;
    const double lateness = (reconnected_ ? kReconnectLatenessS : kMaxLatenessS) * rate;
    const double lo = std::max(static_cast<double>(last_counter_ + 1), predicted - lateness - drift);
    const double hi = predicted + kAheadSlackS * rate + drift + 1;
    bool fits = false;
    if (!f.counter) {
      // No counter: the next sample, after any the decoder rejected.
      counter = last_counter_ + 1 + f.rejected_before;
      fits = static_cast<double>(counter) >= lo && static_cast<double>(counter) <= hi;
    } else if (bits >= 64) {
      counter = static_cast<int64_t>(*f.counter & kCounterMask) + counter_offset_;
      fits = static_cast<double>(counter) >= lo && static_cast<double>(counter) <= hi;
    } else {
      // The candidates counter = raw + offset (mod 2^bits): the one nearest
      // the prediction, but after the last sample.
      const int64_t modulus = int64_t{1} << bits;
      const int64_t base = ((static_cast<int64_t>(*f.counter) + counter_offset_) % modulus + modulus) % modulus;
      int64_t k = static_cast<int64_t>(std::floor((predicted - static_cast<double>(base)) / static_cast<double>(modulus) + 0.5));
      counter = base + k * modulus;
      if (counter <= last_counter_) counter += ((last_counter_ - counter) / modulus + 1) * modulus;
      fits = static_cast<double>(counter) >= lo && static_cast<double>(counter) <= hi;
    }
    if (!fits) {
      // Continue the timeline from the host clock: the frame's arrival is
      // the best estimate of when it was sampled.
      const int64_t placed = std::max<int64_t>(last_counter_ + 1, std::llround(predicted));
      if (f.counter) {
        ++counters_.counter_rebases;
        rebase_log_.Warning("serial " + o_.port.device + ": device counter " + std::to_string(*f.counter) +
                            " after " + std::to_string(last_raw_) +
                            " does not fit the host clock (device restart?); re-based");
        counter_offset_ = placed - static_cast<int64_t>(*f.counter & kCounterMask);
      } else {
        ++counters_.timeline_resyncs;
      }
      counter = placed;
    }
    // The anchor may rise by the drift allowance per second of device time
    // (a slow crystal), and falls to any earlier arrival at once.
    anchor_s_ += kMaxRateError * static_cast<double>(counter - last_counter_) / rate;
  }
  anchor_s_ = std::min(anchor_s_, mono_s - static_cast<double>(counter) / rate);
  if (f.counter) last_raw_ = *f.counter;
  have_last_ = true;
  reconnected_ = false;
  last_counter_ = counter;
  last_mono_s_ = mono_s;
  if (first_counter_ < 0) first_counter_ = counter;
  if (counter - first_counter_ >= total_samples_) {
    ended_ = true;
    return;
  }
  ++counters_.frames;
  q_counter_.push_back(counter);
  q_utime_.push_back(utime);
  for (size_t a = 0; a < o_.axes.size(); ++a) {
    q_values_.push_back(a < f.values.size() ? f.values[a] : std::nanf(""));
    q_flags_.push_back(a < f.flags.size() ? f.flags[a] : 0);
  }
  q_temperature_.push_back(f.temperature_c.value_or(std::nanf("")));
  // The publisher is stuck: keep the newest samples (the dropped ones become
  // a gap downstream, counted here).
  while (static_cast<int64_t>(q_counter_.size()) > queue_limit_) {
    q_counter_.pop_front();
    q_utime_.pop_front();
    q_temperature_.pop_front();
    for (size_t a = 0; a < o_.axes.size(); ++a) {
      q_values_.pop_front();
      q_flags_.pop_front();
    }
    ++counters_.overflow_dropped;
  }
}

Result<int> SerialSource::Read(int max_samples, SampleBlock* block) {
  const size_t axes = o_.axes.size();
  std::lock_guard<std::mutex> lock(mu_);
  block->samples.assign(axes, {});
  block->flags.clear();
  block->temperature_c.reset();
  block->first_sample_utime = 0;
  if (q_counter_.empty()) {
    if (!error_.ok()) return error_;
    if (ended_) return 0;
    return kNoSamplesYet;
  }
  const int64_t first = q_counter_.front();
  size_t n = 0;
  while (n < q_counter_.size() && n < static_cast<size_t>(max_samples) &&
         q_counter_[n] == first + static_cast<int64_t>(n)) {
    ++n;
  }
  // Wait for a full block unless it is cut by a jump, the end, or age.
  const bool cut = n < q_counter_.size();
  if (n < static_cast<size_t>(max_samples) && !cut && !ended_ && error_.ok() &&
      static_cast<double>(HostUtime(MonotonicSeconds()) - q_utime_.front()) * 1e-6 < o_.max_latency_s) {
    return kNoSamplesYet;
  }
  block->first_sample = first;
  block->first_sample_utime = q_utime_.front();
  double temperature_sum = 0;
  int temperatures = 0;
  for (auto& s : block->samples) s.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    for (size_t a = 0; a < axes; ++a) {
      block->samples[a].push_back(q_values_[i * axes + a]);
      const uint8_t bits = q_flags_[i * axes + a];
      if (bits) block->flags.push_back({static_cast<int>(i), static_cast<int>(a), bits});
    }
    if (!std::isnan(q_temperature_[i])) {
      temperature_sum += q_temperature_[i];
      ++temperatures;
    }
  }
  if (temperatures > 0) block->temperature_c = static_cast<float>(temperature_sum / temperatures);
  q_counter_.erase(q_counter_.begin(), q_counter_.begin() + static_cast<std::ptrdiff_t>(n));
  q_utime_.erase(q_utime_.begin(), q_utime_.begin() + static_cast<std::ptrdiff_t>(n));
  q_temperature_.erase(q_temperature_.begin(), q_temperature_.begin() + static_cast<std::ptrdiff_t>(n));
  q_values_.erase(q_values_.begin(), q_values_.begin() + static_cast<std::ptrdiff_t>(n * axes));
  q_flags_.erase(q_flags_.begin(), q_flags_.begin() + static_cast<std::ptrdiff_t>(n * axes));
  return static_cast<int>(n);
}

bool SerialSource::Reconnecting() const {
  std::lock_guard<std::mutex> lock(mu_);
  return reconnecting_ && !ended_;
}

SerialCounters SerialSource::counters() const {
  std::lock_guard<std::mutex> lock(mu_);
  return counters_;
}

void SerialSource::AddCounters(std::map<std::string, int64_t>* out) const {
  const SerialCounters c = counters();
  (*out)["device_frames"] += c.frames;
  (*out)["device_bad_checksum"] += c.bad_checksum;
  (*out)["device_malformed"] += c.malformed;
  (*out)["device_skipped_bytes"] += c.skipped_bytes;
  (*out)["device_other_messages"] += c.other_messages;
  (*out)["device_reconnects"] += c.reconnects;
  (*out)["device_counter_rebases"] += c.counter_rebases;
  (*out)["device_timeline_resyncs"] += c.timeline_resyncs;
  (*out)["device_duplicate_frames"] += c.duplicate_frames;
  (*out)["device_overflow_dropped"] += c.overflow_dropped;
}

}  // namespace imuqual::acquire
