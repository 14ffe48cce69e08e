// Xsens MTi binary output: Xbus MTData2 messages (Xsens "MT Low Level
// Communication Protocol" document).
//
//   0xFA  BID=0xFF  MID=0x36  LEN [EXTLEN_HI EXTLEN_LO if LEN == 0xFF]  DATA  CS
//
// The checksum byte makes the sum of every byte after the preamble zero
// (mod 256). DATA is a sequence of items: a 16-bit big-endian data
// identifier (XDI), an 8-bit size, then the value. The XDI's two low bits
// give the precision (00 float32, 01 fp12.20, 10 fp16.32, 11 float64), bits
// 2-3 the coordinate frame. Used here:
//   0x1020 PacketCounter (uint16, the device sample counter, wraps at 2^16)
//   0x802x RateOfTurn, 0x804x RateOfTurnHR (3 values, rad/s; published in deg/s)
//   0x402x Acceleration, 0x404x AccelerationHR (3 values, m/s^2)
//   0x081x Temperature (deg C)
//   0xE020 StatusWord (bits 8-10 clipping of acc x/y/z, 11-13 of gyr x/y/z)
// Other items are skipped; other messages are counted and skipped. A frame
// that carries both the normal and the HR quantity is read from HR.
#ifndef IMUQUAL_ACQUIRE_XSENS_PROTOCOL_H_
#define IMUQUAL_ACQUIRE_XSENS_PROTOCOL_H_

#include <memory>
#include <vector>

#include "acquire/device_protocol.h"
#include "common/status.h"
#include "imuqual/plan.pb.h"

namespace imuqual::acquire {

namespace xsens {
inline constexpr uint8_t kPreamble = 0xFA;
inline constexpr uint8_t kMasterBid = 0xFF;
inline constexpr uint8_t kMtData2 = 0x36;
inline constexpr int kMaxPayload = 2048;
inline constexpr uint16_t kPacketCounter = 0x1020;
inline constexpr uint16_t kTemperature = 0x0810;
inline constexpr uint16_t kAcceleration = 0x4020;
inline constexpr uint16_t kAccelerationHr = 0x4040;
inline constexpr uint16_t kRateOfTurn = 0x8020;
inline constexpr uint16_t kRateOfTurnHr = 0x8040;
inline constexpr uint16_t kStatusWord = 0xE020;
inline constexpr int kPrecisionFloat32 = 0, kPrecisionFp1220 = 1, kPrecisionFp1632 = 2,
                     kPrecisionFloat64 = 3;
}  // namespace xsens

class XsensDecoder : public FrameDecoder {
 public:
  // `axes` in output order, at most three of each kind: gyro axes read
  // RateOfTurn, accelerometer axes Acceleration; the component is the one the
  // name ends in (x, y or z) when every axis of the kind names a distinct
  // one, else x, y, z in the axes' order.
  static Result<std::unique_ptr<XsensDecoder>> Create(const std::vector<pb::Axis>& axes);

  void Feed(const uint8_t* data, size_t size, std::vector<DeviceFrame>* out) override;
  void Reset() override;
  int counter_bits() const override { return 16; }

 private:
  explicit XsensDecoder(std::vector<AxisComponent> axes) : axes_(std::move(axes)) {}
  // Parses an MTData2 payload; false if its layout is malformed.
  bool Payload(const uint8_t* p, size_t n, std::vector<DeviceFrame>* out);

  std::vector<AxisComponent> axes_;
  std::vector<uint8_t> buf_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_XSENS_PROTOCOL_H_
