// A unit on a serial line: a reader thread owns the port, decodes frames
// (text lines or a vendor binary protocol), places each sample on the
// device's timeline and queues it with its host arrival time; Read(), on the
// publishing thread, takes consecutive samples off the queue and never
// blocks.
//
// The timeline: the device's own counter where the protocol has one,
// unwrapped at its width to the wrap the host clock predicts (so an unplug
// longer than a wrap still lands right); a counter the host clock cannot
// explain (the device restarted) is re-based on the host clock and counted,
// a repeated one dropped. Without a counter, a frame is the sample after the
// last one and any lines the decoder rejected in between, or where the host
// clock puts it after a reconnection or lost output. Missing samples are
// gaps downstream, never invented values. See Accept() for the tolerances.
//
// Unplug: the port is closed, then reopened every 200 ms; after
// reconnect_timeout_s without the device (or without a frame) the source
// fails, which aborts this unit's run only. The run ends after duration_s of
// device time.
#ifndef IMUQUAL_ACQUIRE_SERIAL_SOURCE_H_
#define IMUQUAL_ACQUIRE_SERIAL_SOURCE_H_

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "acquire/device_protocol.h"
#include "acquire/serial_port.h"
#include "acquire/source.h"
#include "common/log.h"

namespace imuqual::acquire {

struct SerialSourceOptions {
  SerialPortOptions port;
  std::string protocol;              // for the description: "text", "xsens"
  std::vector<pb::Axis> axes;        // the decoder's output order
  double rate_hz = 0;                // nominal output data rate
  double duration_s = 0;             // device time to record, > 0
  double reconnect_timeout_s = 30;   // device gone (or silent) this long fails the run
  double max_latency_s = 0.25;       // a part-filled block is released after this
  double queue_limit_s = 600;        // samples held for the publisher at most (then oldest dropped)
};

struct SerialCounters {
  int64_t frames = 0;            // frames accepted onto the timeline
  int64_t bad_checksum = 0;
  int64_t malformed = 0;
  int64_t skipped_bytes = 0;
  int64_t other_messages = 0;
  int64_t reconnects = 0;
  int64_t counter_rebases = 0;   // counters the host clock could not explain (device restart)
  int64_t timeline_resyncs = 0;  // counter-less frames placed by the host clock (lost output)
  int64_t duplicate_frames = 0;  // same counter twice
  int64_t overflow_dropped = 0;  // samples dropped because the publisher fell behind
};

class SerialSource : public SampleSource {
 public:
  // Opens the port once (a unit that is not there at the start is an error
  // naming the device) and starts the reader.
  static Result<std::unique_ptr<SerialSource>> Open(SerialSourceOptions options,
                                                    std::unique_ptr<FrameDecoder> decoder);
  ~SerialSource() override;
  // Ends the reader thread (joined) and closes the port.
  void Stop() override;

  const SourceInfo& info() const override { return info_; }
  Result<int> Read(int max_samples, SampleBlock* block) override;
  void AddCounters(std::map<std::string, int64_t>* counters) const override;
  bool Reconnecting() const override;
  SerialCounters counters() const;

 private:
  SerialSource(SerialSourceOptions options, std::unique_ptr<FrameDecoder> decoder, SerialPort port);
  void ReaderLoop();
  // Places a decoded frame on the timeline and queues it (mu_ held).
  void Accept(const DeviceFrame& frame, double mono_s, int64_t utime);
  int64_t HostUtime(double mono_s) const;
  void WaitStop(double seconds);

  SerialSourceOptions o_;
  SourceInfo info_;
  std::unique_ptr<FrameDecoder> decoder_;   // reader thread only
  std::optional<SerialPort> port_;          // reader thread only
  double origin_mono_s_ = 0;
  int64_t origin_utime_ = 0;
  int64_t total_samples_ = 0;
  int64_t queue_limit_ = 0;

  mutable std::mutex mu_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  // Timeline (mu_).
  bool have_last_ = false;
  bool reconnected_ = false;
  bool reconnecting_ = false;  // the device is gone, or reopened with no frame since
  uint64_t last_raw_ = 0;
  int64_t last_counter_ = 0;
  int64_t counter_offset_ = 0;  // timeline counter - device counter (mod its wrap)
  double anchor_s_ = 0;         // least-late arrival: mono - counter / rate
  double last_mono_s_ = 0;
  ThrottledLog rebase_log_;
  int64_t first_counter_ = -1;
  bool ended_ = false;            // duration reached: no more samples
  Status error_;                  // the reader gave up
  SerialCounters counters_;
  // Queue (mu_): one entry per sample.
  std::deque<int64_t> q_counter_;
  std::deque<int64_t> q_utime_;
  std::deque<float> q_values_;    // axes per sample
  std::deque<uint8_t> q_flags_;
  std::deque<float> q_temperature_;  // NaN: none
  std::thread reader_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_SERIAL_SOURCE_H_
