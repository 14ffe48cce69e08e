// What a serial device's byte stream decodes into: frames, each one sample
// of every configured axis with the device's own sample counter when the
// protocol carries one. A decoder is pure (bytes in, frames out), keeps the
// bytes of an unfinished frame between calls, and never trusts a byte it
// cannot check: a frame that fails its checksum or its layout is counted and
// skipped, and decoding resynchronises on the next frame start.
#ifndef IMUQUAL_ACQUIRE_DEVICE_PROTOCOL_H_
#define IMUQUAL_ACQUIRE_DEVICE_PROTOCOL_H_

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "imuqual/plan.pb.h"

namespace imuqual::acquire {

struct DeviceFrame {
  std::optional<uint64_t> counter;  // raw device counter (wraps at counter_bits)
  std::vector<float> values;        // per configured axis; NaN when the frame lacks it
  std::vector<uint8_t> flags;       // per axis rate_batch_t FLAG_* bits
  std::optional<float> temperature_c;
  int64_t rejected_before = 0;  // frames rejected since the previous good one
};

struct DecoderCounters {
  int64_t frames = 0;          // frames decoded
  int64_t bad_checksum = 0;    // frames whose checksum failed
  int64_t malformed = 0;       // frames with a bad length, layout or value
  int64_t skipped_bytes = 0;   // bytes discarded while looking for a frame start
  int64_t other_messages = 0;  // well-formed messages that carry no samples
};

class FrameDecoder {
 public:
  virtual ~FrameDecoder() = default;
  // Decodes `size` more bytes; appends the frames they complete to *out.
  virtual void Feed(const uint8_t* data, size_t size, std::vector<DeviceFrame>* out) = 0;
  // Drops an unfinished frame (the device was reconnected mid-frame).
  virtual void Reset() = 0;
  // Width of the device counter in bits (it wraps at 2^bits); 0 when the
  // protocol has no counter and frames carry none.
  virtual int counter_bits() const = 0;
  const DecoderCounters& counters() const { return counters_; }

 protected:
  DecoderCounters counters_;
};

// Which component of a device's gyro or accelerometer triple each
// configured axis reads.
struct AxisComponent {
  bool gyro = true;
  int component = 0;  // 0, 1, 2: x (roll), y (pitch), z (yaw)
};

// The component of every axis of `axes`, for a device with one gyro and one
// accelerometer triple: by the name's last letter (gx, gy, gz; gyro_z; ...)
// when every axis of a kind names a distinct one, else in the axes' order.
// More than three axes of a kind is an error naming `protocol` and the axis.
Result<std::vector<AxisComponent>> AssignTripleComponents(const std::vector<pb::Axis>& axes,
                                                          std::string_view protocol);

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_DEVICE_PROTOCOL_H_
