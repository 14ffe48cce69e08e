// The serial protocols' decoders: a hand-checked Xsens MTData2 frame, every
// precision, checksum failures, garbage, partial frames split at every byte;
// the text-line protocol's columns, scales, NMEA checksums and bad lines.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include "acquire/text_protocol.h"
#include "acquire/xsens_protocol.h"
#include "imuqual/rate_batch_t.hpp"

namespace imuqual::acquire {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Counter 0x1234, RateOfTurn (0.5, -0.25, 1.0) rad/s, Acceleration
// (9.75, 0, -1) m/s^2, all float32; checksum worked out by hand.
const std::vector<uint8_t> kGolden = {
    0xFA, 0xFF, 0x36, 0x23, 0x10, 0x20, 0x02, 0x12, 0x34, 0x80, 0x20, 0x0C, 0x3F, 0x00,
    0x00, 0x00, 0xBE, 0x80, 0x00, 0x00, 0x3F, 0x80, 0x00, 0x00, 0x40, 0x20, 0x0C, 0x41,
    0x1C, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xBF, 0x80, 0x00, 0x00, 0x40};

std::vector<pb::Axis> Axes(const std::vector<std::pair<std::string, pb::AxisKind>>& list) {
  std::vector<pb::Axis> out;
  for (const auto& [name, kind] : list) {
    pb::Axis a;
    a.set_name(name);
    a.set_kind(kind);
    out.push_back(a);
  }
  return out;
}

std::vector<pb::Axis> SixAxes() {
  return Axes({{"gx", pb::GYRO}, {"gy", pb::GYRO}, {"gz", pb::GYRO},
               {"ax", pb::ACCEL}, {"ay", pb::ACCEL}, {"az", pb::ACCEL}});
}

// A test-side MTData2 writer, independent of the decoder.
class Frame {
 public:
  Frame& U16(uint16_t xdi, uint16_t v) {
    Item(xdi, 2);
    Put(v >> 8);
    Put(v & 0xFF);
    return *this;
  }
  Frame& U32(uint16_t xdi, uint32_t v) {
    Item(xdi, 4);
    for (int s = 24; s >= 0; s -= 8) Put((v >> s) & 0xFF);
    return *this;
  }
  Frame& Floats(uint16_t xdi, std::vector<float> v) {
    Item(xdi, static_cast<uint8_t>(4 * v.size()));
    for (float f : v) {
      uint32_t bits;
      std::memcpy(&bits, &f, 4);
      for (int s = 24; s >= 0; s -= 8) Put((bits >> s) & 0xFF);
    }
    return *this;
  }
  Frame& Raw(uint16_t xdi, std::vector<uint8_t> bytes) {
    Item(xdi, static_cast<uint8_t>(bytes.size()));
    for (uint8_t b : bytes) Put(b);
    return *this;
  }
  std::vector<uint8_t> Bytes(uint8_t mid = 0x36, bool extended = false) const {
    std::vector<uint8_t> m = {0xFA, 0xFF, mid};
    if (extended || payload_.size() >= 255) {
      m.push_back(0xFF);
      m.push_back(static_cast<uint8_t>(payload_.size() >> 8));
      m.push_back(static_cast<uint8_t>(payload_.size() & 0xFF));
    } else {
      m.push_back(static_cast<uint8_t>(payload_.size()));
    }
    m.insert(m.end(), payload_.begin(), payload_.end());
    uint8_t sum = 0;
    for (size_t i = 1; i < m.size(); ++i) sum = static_cast<uint8_t>(sum + m[i]);
    m.push_back(static_cast<uint8_t>(-sum));
    return m;
  }

 private:
  void Item(uint16_t xdi, uint8_t size) {
    Put(xdi >> 8);
    Put(xdi & 0xFF);
    Put(size);
  }
  void Put(unsigned v) { payload_.push_back(static_cast<uint8_t>(v)); }
  std::vector<uint8_t> payload_;
};

std::vector<DeviceFrame> Decode(FrameDecoder& d, const std::vector<uint8_t>& bytes) {
  std::vector<DeviceFrame> out;
  d.Feed(bytes.data(), bytes.size(), &out);
  return out;
}

TEST(XsensDecoderTest, GoldenFrameDecodesToDegreesPerSecondAndTheCounter) {
  auto d = XsensDecoder::Create(SixAxes());
  ASSERT_TRUE(d.ok());
  const auto frames = Decode(**d, kGolden);
  ASSERT_EQ(frames.size(), 1u);
  const DeviceFrame& f = frames[0];
  ASSERT_TRUE(f.counter.has_value());
  EXPECT_EQ(*f.counter, 0x1234u);
  EXPECT_EQ(f.values[0], static_cast<float>(0.5 * kDegPerRad));
  EXPECT_EQ(f.values[1], static_cast<float>(-0.25 * kDegPerRad));
  EXPECT_EQ(f.values[2], static_cast<float>(1.0 * kDegPerRad));
  EXPECT_EQ(f.values[3], 9.75f);
  EXPECT_EQ(f.values[4], 0.0f);
  EXPECT_EQ(f.values[5], -1.0f);
  EXPECT_EQ(f.flags, std::vector<uint8_t>(6, 0));
  EXPECT_EQ((*d)->counter_bits(), 16);
  EXPECT_EQ((*d)->counters().frames, 1);
  EXPECT_EQ((*d)->counters().bad_checksum, 0);
}

TEST(XsensDecoderTest, EverySplitOfTwoFramesGivesTheSameFrames) {
  std::vector<uint8_t> two = kGolden;
  two.insert(two.end(), kGolden.begin(), kGolden.end());
  for (size_t cut = 0; cut <= two.size(); ++cut) {
    auto d = XsensDecoder::Create(SixAxes());
    std::vector<DeviceFrame> out;
    (*d)->Feed(two.data(), cut, &out);
    (*d)->Feed(two.data() + cut, two.size() - cut, &out);
    ASSERT_EQ(out.size(), 2u) << "cut at " << cut;
    EXPECT_EQ((*d)->counters().skipped_bytes, 0) << cut;
  }
  // Byte by byte.
  auto d = XsensDecoder::Create(SixAxes());
  std::vector<DeviceFrame> out;
  for (uint8_t b : two) (*d)->Feed(&b, 1, &out);
  EXPECT_EQ(out.size(), 2u);
}

TEST(XsensDecoderTest, CorruptFrameIsCountedAndTheNextOneFound) {
  for (size_t flip = 1; flip < kGolden.size(); ++flip) {
    std::vector<uint8_t> bytes = kGolden;
    bytes[flip] ^= 0x10;  // any single-bit error in BID..CS
    bytes.insert(bytes.end(), kGolden.begin(), kGolden.end());
    auto d = XsensDecoder::Create(SixAxes());
    const auto frames = Decode(**d, bytes);
    // The good frame always survives; the damaged one never does.
    ASSERT_EQ(frames.size(), 1u) << "flip at " << flip;
    EXPECT_EQ(*frames[0].counter, 0x1234u);
    const DecoderCounters& c = (*d)->counters();
    EXPECT_GE(c.bad_checksum + c.malformed + c.skipped_bytes, 1) << flip;
  }
}

TEST(XsensDecoderTest, GarbagePartialFramesAndOtherMessagesAreSkipped) {
  std::vector<uint8_t> bytes = {0x00, 0xFA, 0x12, 0xFA, 0xFF, 0x36};  // junk, false starts
  bytes.insert(bytes.end(), kGolden.begin(), kGolden.begin() + 17);  // a partial frame
  bytes.insert(bytes.end(), kGolden.begin(), kGolden.end());
  const auto wakeup = Frame().Bytes(0x3E);  // WakeUp: not data
  bytes.insert(bytes.end(), wakeup.begin(), wakeup.end());
  // "0xFA 0xFF 0x36 0xFA" above reads as a 250-byte frame: the decoder waits
  // for that much before its checksum fails; the stream goes on meanwhile.
  for (int i = 0; i < 8; ++i) bytes.insert(bytes.end(), kGolden.begin(), kGolden.end());
  auto d = XsensDecoder::Create(SixAxes());
  const auto frames = Decode(**d, bytes);
  EXPECT_EQ(frames.size(), 9u);  // the whole ones: 1 + 8
  EXPECT_EQ((*d)->counters().other_messages, 1);
  EXPECT_GE((*d)->counters().bad_checksum, 1);
}

TEST(XsensDecoderTest, FixedPointAndDoublePrecisionsAndExtendedLength) {
  // fp12.20: -1.25 rad/s = -1310720 / 2^20; fp16.32: 2.5 m/s^2 (fraction
  // 0x80000000, integer 2); float64: -0.125 rad/s.
  const int32_t fp1220 = -1310720;
  const uint32_t u = static_cast<uint32_t>(fp1220);
  std::vector<uint8_t> gyro;
  for (int i = 0; i < 3; ++i) {
    for (int s = 24; s >= 0; s -= 8) gyro.push_back(static_cast<uint8_t>(u >> s));
  }
  std::vector<uint8_t> acc;
  constexpr uint8_t kTwoAndAHalf[6] = {0x80, 0x00, 0x00, 0x00, 0x00, 0x02};
  for (int i = 0; i < 3; ++i) {
    for (uint8_t b : kTwoAndAHalf) acc.push_back(b);
  }
  double minus_eighth = -0.125;
  uint64_t bits;
  std::memcpy(&bits, &minus_eighth, 8);
  std::vector<uint8_t> gyro_hr;
  for (int i = 0; i < 3; ++i) {
    for (int s = 56; s >= 0; s -= 8) gyro_hr.push_back(static_cast<uint8_t>(bits >> s));
  }
  Frame f;
  f.U16(0x1020, 7).Raw(0x8021, gyro).Raw(0x4022, acc);
  auto d = XsensDecoder::Create(SixAxes());
  auto frames = Decode(**d, f.Bytes(0x36, /*extended=*/true));
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_FLOAT_EQ(frames[0].values[0], static_cast<float>(-1.25 * kDegPerRad));
  EXPECT_EQ(frames[0].values[3], 2.5f);
  // RateOfTurnHR wins over RateOfTurn in the same frame, in either order.
  Frame hr;
  hr.U16(0x1020, 8).Raw(0x8043, gyro_hr).Raw(0x8021, gyro);
  frames = Decode(**d, hr.Bytes());
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].values[1], static_cast<float>(-0.125 * kDegPerRad));
  Frame hr_last;
  hr_last.U16(0x1020, 9).Raw(0x8021, gyro).Raw(0x8043, gyro_hr);
  frames = Decode(**d, hr_last.Bytes());
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].values[1], static_cast<float>(-0.125 * kDegPerRad));
  // The frame lacks acceleration: those axes are invalid, not zero.
  EXPECT_TRUE(std::isnan(frames[0].values[4]));
  EXPECT_EQ(frames[0].flags[4], imuqual::rate_batch_t::FLAG_INVALID);
}

TEST(XsensDecoderTest, NegativeFp1632) {
  // -2.25 = integer part -3 (0xFFFD), fraction 0.75 (0xC0000000).
  std::vector<uint8_t> acc;
  constexpr uint8_t kMinusTwoAndAQuarter[6] = {0xC0, 0x00, 0x00, 0x00, 0xFF, 0xFD};
  for (int i = 0; i < 3; ++i) {
    for (uint8_t b : kMinusTwoAndAQuarter) acc.push_back(b);
  }
  Frame f;
  f.U16(0x1020, 1).Raw(0x4022, acc);
  auto d = XsensDecoder::Create(Axes({{"ax", pb::ACCEL}}));
  const auto frames = Decode(**d, f.Bytes());
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].values[0], -2.25f);
}

TEST(XsensDecoderTest, AxesTakeTheComponentTheirNameEndsIn) {
  Frame f;
  f.U16(0x1020, 1).Floats(0x8020, {1, 2, 3}).Floats(0x4020, {4, 5, 6});
  // By name: z alone; z, x out of order; accelerometer y.
  auto d = XsensDecoder::Create(Axes({{"gyro_z", pb::GYRO}, {"gx", pb::GYRO}, {"acc_y", pb::ACCEL}}));
  ASSERT_TRUE(d.ok());
  auto frames = Decode(**d, f.Bytes());
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].values, (std::vector<float>{static_cast<float>(3 * kDegPerRad),
                                                  static_cast<float>(1 * kDegPerRad), 5.0f}));
  // Names that do not say: in order.
  auto in_order = XsensDecoder::Create(Axes({{"roll", pb::GYRO}, {"pitch", pb::GYRO}}));
  frames = Decode(**in_order, f.Bytes());
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].values[1], static_cast<float>(2 * kDegPerRad));
}

TEST(XsensDecoderTest, StatusWordClippingFlagsSaturationPerAxis) {
  Frame f;
  f.U16(0x1020, 1)
      .Floats(0x8020, {0.1f, 0.2f, 0.3f})
      .Floats(0x4020, {1, 2, 3})
      .U32(0xE020, (1u << 12) | (1u << 8));  // ClipGyrY, ClipAccX
  auto d = XsensDecoder::Create(SixAxes());
  const auto frames = Decode(**d, f.Bytes());
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].flags, (std::vector<uint8_t>{0, 1, 0, 1, 0, 0}));
}

TEST(XsensDecoderTest, ItemOverrunningThePayloadIsMalformed) {
  Frame f;
  f.U16(0x1020, 1).Raw(0x8020, {1, 2, 3});  // 3 bytes where 12 are due
  auto d = XsensDecoder::Create(SixAxes());
  EXPECT_TRUE(Decode(**d, f.Bytes()).empty());
  EXPECT_EQ((*d)->counters().malformed, 1);
}

TEST(XsensDecoderTest, RejectsAFourthGyroAxis) {
  auto d = XsensDecoder::Create(Axes({{"a", pb::GYRO}, {"b", pb::GYRO}, {"c", pb::GYRO}, {"d", pb::GYRO}}));
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.status().message().find("'d'"), std::string::npos);
}

// --- text lines ---

std::unique_ptr<TextLineDecoder> Text(TextProtocolOptions o) {
  auto d = TextLineDecoder::Create(std::move(o));
  EXPECT_TRUE(d.ok()) << d.status().message();
  return std::move(*d);
}

std::vector<DeviceFrame> DecodeText(TextLineDecoder& d, const std::string& s) {
  std::vector<DeviceFrame> out;
  d.Feed(reinterpret_cast<const uint8_t*>(s.data()), s.size(), &out);
  return out;
}

TEST(TextLineDecoderTest, ColumnsScalesCounterTemperatureAndAPartialFirstLine) {
  TextProtocolOptions o;
  o.columns = {"count", "gx", "_", "gz", "temp"};
  o.axes = {"gz", "gx"};
  o.scales = {0.001, 2};
  o.counter_column = "count";
  o.temperature_column = "temp";
  auto d = Text(o);
  const auto frames =
      DecodeText(*d, "3,9,9,9,9\r\n7,1.5,x,-2000,25.5\r\n# firmware 1.2\n\n8,nan,0,1,26\n9,1,2\n");
  // The first line may have started before we listened: skipped.
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(*frames[0].counter, 7u);
  EXPECT_EQ(frames[0].values, (std::vector<float>{-2.0f, 3.0f}));
  EXPECT_EQ(*frames[0].temperature_c, 25.5f);
  EXPECT_TRUE(std::isnan(frames[1].values[1]));
  EXPECT_EQ(frames[1].flags[1], imuqual::rate_batch_t::FLAG_INVALID);
  EXPECT_EQ(d->counters().other_messages, 1);
  EXPECT_EQ(d->counters().malformed, 1);  // "9,1,2": too few fields
  EXPECT_EQ(d->counters().skipped_bytes, 11);
  EXPECT_EQ(d->counter_bits(), 64);
}

TEST(TextLineDecoderTest, NmeaChecksumAndWhitespaceFields) {
  TextProtocolOptions o;
  o.columns = {"n", "gx"};
  o.axes = {"gx"};
  o.counter_column = "n";
  o.counter_bits = 16;
  o.delimiter = ' ';
  o.nmea_checksum = true;
  auto d = Text(o);
  auto line = [](const std::string& body) {
    uint8_t x = 0;
    for (char c : body) x ^= static_cast<uint8_t>(c);
    char hex[4];
    std::snprintf(hex, sizeof hex, "%02X", x);
    return "$" + body + "*" + hex + "\n";
  };
  std::string good = line("65535  0.25");
  std::string bad = line("12 0.5");
  bad[2] = '3';  // corrupted in transit
  const auto frames = DecodeText(*d, "\n" + good + bad + line("70000 1") + "$1 2\n" + line("0\t-1"));
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(*frames[0].counter, 65535u);
  EXPECT_EQ(frames[0].values[0], 0.25f);
  EXPECT_EQ(*frames[1].counter, 0u);
  EXPECT_EQ(d->counters().bad_checksum, 1);
  EXPECT_EQ(d->counters().malformed, 2);  // counter over 16 bits, no checksum
}

TEST(TextLineDecoderTest, OverlongLineIsDroppedWholeAndDecodingGoesOn) {
  TextProtocolOptions o;
  o.columns = {"gx"};
  o.axes = {"gx"};
  o.max_line = 16;
  auto d = Text(o);
  const auto frames = DecodeText(*d, "\n1\n" + std::string(100, '7') + "\n2\n");
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].values[0], 2.0f);
  EXPECT_EQ(d->counters().malformed, 1);
  EXPECT_EQ(d->counter_bits(), 0);
}

TEST(TextLineDecoderTest, ConfigurationErrorsNameTheProblem) {
  TextProtocolOptions o;
  o.columns = {"a", "b"};
  o.axes = {"c"};
  auto d = TextLineDecoder::Create(o);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.status().message().find("'c'"), std::string::npos);
  o.axes = {"a"};
  o.counter_column = "n";
  EXPECT_FALSE(TextLineDecoder::Create(o).ok());
  o.counter_column = "";
  o.columns = {"a", "a"};
  EXPECT_FALSE(TextLineDecoder::Create(o).ok());
}

}  // namespace
}  // namespace imuqual::acquire
