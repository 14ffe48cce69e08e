// Crossbow (Moog) 700-series DMU / VG700 binary output in scaled sensor mode
// (VG700M User's Manual, doc. 7430-0280-01 rev. F, section 3.6, table 3 and
// appendix B; VG700MB-200 and VG700MC-208):
//
//   byte 0       header, 255
//   bytes 1-12   roll, pitch, yaw rate, then acceleration x, y, z: 16-bit
//                big-endian two's complement words
//   bytes 13-14  temperature sensor voltage, unsigned
//   bytes 15-16  timer, unsigned (a free-running clock, not a sample counter)
//   byte 17      checksum
//
//   rate  [deg/s] = word x RR x 1.5 / (2^15 - 1)   RR: the rate range, deg/s
//   accel [g]     = word x GR x 1.5 / (2^15 - 1)   GR: the accelerometer range, g
//   temperature [deg C] = (word x 5 / 4096 - 1.375) x 44.44
//
// The ranges are the model's configuration (e.g. +-200 deg/s, +-4 g): the
// packet does not carry them. A word at +-32767 (or -32768) is the sensor at
// the end of its scale: flagged saturated.
//
// The manual contradicts itself on the checksum: section 3.6 says "sum all
// packet contents except header and checksum, divide the sum by 256, the
// remainder should equal the checksum" and, a paragraph later for the same
// scaled mode, "divide the sum by 255". Both readings are implemented
// (CrossbowChecksum); kEither accepts a packet that meets either (the default:
// a corrupt packet then passes with probability about 2/256 instead of 1/256;
// naming the unit's rule halves that). The VG700MB-206's packet (a 0xAA 0x55
// header, a 16-bit checksum) is another layout and is not decoded here.
//
// The timer is not a sample counter, so frames carry none: the serial source
// places them after the previous one, leaving room for the packets lost in
// between (DeviceFrame::rejected_before: the bytes skipped since the last
// good packet, in packets, at least one), checked against the host clock.
// Resynchronisation after corruption: a packet that fails its checksum gives
// up its header byte only, and the search for 255 starts again at the next
// byte; out of sync (at the start, after a skipped byte), a packet is taken
// only when the next packet's header byte follows it, so that a stray 255
// with a checksum that holds by chance (1 in 128-256) is not taken for a
// sample (1 in 2^15-2^16 with the next header).
#ifndef IMUQUAL_ACQUIRE_CROSSBOW_PROTOCOL_H_
#define IMUQUAL_ACQUIRE_CROSSBOW_PROTOCOL_H_

#include <memory>
#include <vector>

#include "acquire/device_protocol.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"

namespace imuqual::acquire {

namespace crossbow {
inline constexpr uint8_t kHeader = 255;
inline constexpr size_t kScaledPacketBytes = 18;
}  // namespace crossbow

enum class CrossbowChecksum {
  kMod256,  // sum of bytes 1-16 modulo 256 (section 3.6, first paragraph)
  kMod255,  // the same sum modulo 255 (section 3.6, second paragraph)
  kEither,  // a packet that meets either
};

struct CrossbowOptions {
  std::vector<pb::Axis> axes;  // output order; at most 3 gyro and 3 accelerometer axes
  double rate_range_dps = 0;   // RR, > 0 when there is a gyro axis
  double g_range = 0;          // GR, > 0 when there is an accelerometer axis
  CrossbowChecksum checksum = CrossbowChecksum::kEither;
};

class CrossbowDecoder : public FrameDecoder {
 public:
  // Gyro axes read roll, pitch, yaw rate, accelerometer axes acceleration
  // x, y, z: the component the name ends in (x, y or z) when every axis of a
  // kind names a distinct one, else in the axes' order.
  static Result<std::unique_ptr<CrossbowDecoder>> Create(const CrossbowOptions& options);

  void Feed(const uint8_t* data, size_t size, std::vector<DeviceFrame>* out) override;
  void Reset() override;
  int counter_bits() const override { return 0; }

  // The checksum byte of packet bytes 1-16 under `rule` (kMod256 or kMod255).
  static uint8_t Checksum(const uint8_t* packet, CrossbowChecksum rule);

 private:
  CrossbowDecoder(CrossbowOptions options, std::vector<AxisComponent> axes)
      : options_(std::move(options)), axes_(std::move(axes)) {}

  CrossbowOptions options_;
  std::vector<AxisComponent> axes_;
  std::vector<uint8_t> buf_;
  bool in_sync_ = false;              // the last bytes were a good packet: the next starts here
  bool have_packet_ = false;          // a good packet since the start or the last Reset
  int64_t skipped_since_packet_ = 0;  // bytes skipped since the last good packet
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_CROSSBOW_PROTOCOL_H_
