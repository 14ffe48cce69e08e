// The Crossbow 700-series decoder (scaled sensor mode): the manual's scaling,
// both readings of its self-contradicting checksum, saturation, resync after
// corruption; and a source on a pseudo-terminal, as a unit on a serial line.
#include "acquire/crossbow_protocol.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "acquire/source_spec.h"
#include "common/clock.h"
#include "imuqual/rate_batch_t.hpp"
#include "tests/pty_device.h"
#include "tests/test_util.h"

namespace imuqual::acquire {
namespace {

// Roll/pitch/yaw rate words, acceleration words, temperature and timer words.
std::vector<uint8_t> Packet(const std::vector<int16_t>& words, uint16_t temperature, uint16_t timer,
                            CrossbowChecksum rule) {
  std::vector<uint8_t> p = {crossbow::kHeader};
  for (int16_t w : words) {
    const auto u = static_cast<uint16_t>(w);
    p.push_back(static_cast<uint8_t>(u >> 8));
    p.push_back(static_cast<uint8_t>(u & 0xFF));
  }
  for (uint16_t u : {temperature, timer}) {
    p.push_back(static_cast<uint8_t>(u >> 8));
    p.push_back(static_cast<uint8_t>(u & 0xFF));
  }
  p.push_back(0);
  p.back() = CrossbowDecoder::Checksum(p.data(), rule);
  return p;
}

std::vector<pb::Axis> SixAxes() {
  std::vector<pb::Axis> axes;
  for (const char* name : {"gx", "gy", "gz", "ax", "ay", "az"}) {
    pb::Axis a;
    a.set_name(name);
    a.set_kind(name[0] == 'g' ? pb::GYRO : pb::ACCEL);
    axes.push_back(a);
  }
  return axes;
}

std::unique_ptr<CrossbowDecoder> Decoder(CrossbowChecksum rule) {
  CrossbowOptions o;
  o.axes = SixAxes();
  o.rate_range_dps = 200;
  o.g_range = 4;
  o.checksum = rule;
  auto d = CrossbowDecoder::Create(o);
  EXPECT_TRUE(d.ok()) << d.status().message();
  return std::move(*d);
}

TEST(CrossbowDecoderTest, ScaledSensorModeAsTheManualConvertsIt) {
  auto d = Decoder(CrossbowChecksum::kMod256);
  // GIVEN words for 1000, -2000, 32767 (saturated), 16384, 0, -16384 and a
  // temperature word of 1126 (about 0 deg C: (1126 x 5/4096 - 1.375) x 44.44)
  const std::vector<uint8_t> p =
      Packet({1000, -2000, 32767, 16384, 0, -16384}, 1126, 40000, CrossbowChecksum::kMod256);
  ASSERT_EQ(p.size(), crossbow::kScaledPacketBytes);
  std::vector<DeviceFrame> frames;
  d->Feed(p.data(), p.size(), &frames);
  EXPECT_EQ(frames.size(), 0u);  // out of sync: taken once the next packet's header follows
  const uint8_t next_header = crossbow::kHeader;
  d->Feed(&next_header, 1, &frames);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].rejected_before, 0);
  const DeviceFrame& f = frames[0];
  // THEN rate = word x 200 x 1.5 / 32767 deg/s, accel = word x 4 x 1.5 / 32767 g
  EXPECT_FLOAT_EQ(f.values[0], static_cast<float>(1000 * 300.0 / 32767));
  EXPECT_FLOAT_EQ(f.values[1], static_cast<float>(-2000 * 300.0 / 32767));
  EXPECT_EQ(f.flags[2], imuqual::rate_batch_t::FLAG_SATURATED);
  EXPECT_EQ(f.flags[0], 0);
  EXPECT_FLOAT_EQ(f.values[3], static_cast<float>(16384 * 6.0 / 32767 * 9.80665));
  EXPECT_FLOAT_EQ(f.values[5], static_cast<float>(-16384 * 6.0 / 32767 * 9.80665));
  ASSERT_TRUE(f.temperature_c.has_value());
  EXPECT_NEAR(*f.temperature_c, (1126 * 5.0 / 4096 - 1.375) * 44.44, 1e-4);
  EXPECT_FALSE(f.counter.has_value());  // the timer is a clock, not a counter
}

TEST(CrossbowDecoderTest, BothReadingsOfTheChecksum) {
  // A packet whose byte sum differs modulo 256 and modulo 255 (sum >= 255).
  const std::vector<int16_t> words = {1000, 2000, 3000, 4000, 5000, 6000};
  const auto p256 = Packet(words, 1126, 7, CrossbowChecksum::kMod256);
  const auto p255 = Packet(words, 1126, 7, CrossbowChecksum::kMod255);
  ASSERT_NE(p256.back(), p255.back());
  for (const auto& [rule, accepts256, accepts255] :
       std::vector<std::tuple<CrossbowChecksum, bool, bool>>{
           {CrossbowChecksum::kMod256, true, false},
           {CrossbowChecksum::kMod255, false, true},
           {CrossbowChecksum::kEither, true, true}}) {
    for (const auto& [packet, accepts] : {std::pair{p256, accepts256}, std::pair{p255, accepts255}}) {
      auto d = Decoder(rule);
      std::vector<uint8_t> bytes = packet;
      bytes.push_back(crossbow::kHeader);  // the next packet's start
      std::vector<DeviceFrame> frames;
      d->Feed(bytes.data(), bytes.size(), &frames);
      EXPECT_EQ(frames.size(), accepts ? 1u : 0u);
    }
  }
}

TEST(CrossbowDecoderTest, ResynchronisesAfterCorruptionAndSplitReads) {
  auto d = Decoder(CrossbowChecksum::kEither);
  std::vector<uint8_t> stream = {1, 2, 255, 255};  // noise, including a stray header
  std::vector<uint8_t> bad =
      Packet({255, 255, 255, 255, 255, 255}, 255, 255, CrossbowChecksum::kMod256);
  bad[5] ^= 0x40;  // a flipped bit: the checksum no longer holds
  stream.insert(stream.end(), bad.begin(), bad.end());
  for (int k = 0; k < 20; ++k) {
    const auto p = Packet({static_cast<int16_t>(k), 0, 0, 0, 0, 0}, 1126, static_cast<uint16_t>(k),
                          CrossbowChecksum::kMod256);
    stream.insert(stream.end(), p.begin(), p.end());
  }
  // Fed in pieces of 7 bytes, as a serial port delivers them.
  std::vector<DeviceFrame> frames;
  for (size_t at = 0; at < stream.size(); at += 7) {
    d->Feed(stream.data() + at, std::min<size_t>(7, stream.size() - at), &frames);
  }
  ASSERT_EQ(frames.size(), 20u);
  for (int k = 0; k < 20; ++k) {
    EXPECT_FLOAT_EQ(frames[k].values[0], static_cast<float>(k * 300.0 / 32767)) << k;
  }
  EXPECT_GE(d->counters().bad_checksum, 1);
  EXPECT_EQ(d->counters().frames, 20);
}

// Out of sync, a stray 255 followed by 17 bytes whose checksum holds by
// chance is not a sample: the next packet's header must follow it. In sync,
// every good packet is taken as it completes.
TEST(CrossbowDecoderTest, AChanceChecksumWhileResyncingIsNoSample) {
  auto d = Decoder(CrossbowChecksum::kMod256);
  // A false packet: header, words, a checksum that holds, then noise (not 255).
  std::vector<uint8_t> stream = Packet({111, 0, 0, 0, 0, 0}, 1, 2, CrossbowChecksum::kMod256);
  stream.push_back(7);
  for (int k = 0; k < 5; ++k) {
    const auto p = Packet({static_cast<int16_t>(k), 0, 0, 0, 0, 0}, 1126, 0,
                          CrossbowChecksum::kMod256);
    stream.insert(stream.end(), p.begin(), p.end());
  }
  std::vector<DeviceFrame> frames;
  d->Feed(stream.data(), stream.size(), &frames);
  // The first real packet waits for the second's header; the last is taken
  // in sync without waiting.
  ASSERT_EQ(frames.size(), 5u);
  for (int k = 0; k < 5; ++k) EXPECT_FLOAT_EQ(frames[k].values[0], k * 300.0f / 32767) << k;
  EXPECT_EQ(frames[0].rejected_before, 0);  // nothing good came before it
}

// Packets lost between two good ones are counted in the next good frame
// (rejected_before), so that a counter-less source keeps the time axis: one
// corrupted packet, one cut short by an overrun (3 bytes lost), two
// corrupted in a row.
TEST(CrossbowDecoderTest, LostPacketsAreCountedForThePlacementOfTheNext) {
  auto d = Decoder(CrossbowChecksum::kMod256);
  auto good = [](int k) {
    return Packet({static_cast<int16_t>(k), 0, 0, 0, 0, 0}, 1126, 0, CrossbowChecksum::kMod256);
  };
  auto corrupt = [&](int k) {
    auto p = good(k);
    p[3] ^= 0x10;
    return p;
  };
  std::vector<uint8_t> stream;
  auto add = [&](const std::vector<uint8_t>& p) { stream.insert(stream.end(), p.begin(), p.end()); };
  add(good(0));
  add(good(1));
  add(corrupt(2));
  add(good(3));
  auto cut = good(4);
  cut.erase(cut.begin() + 5, cut.begin() + 8);
  add(cut);
  add(good(5));
  add(corrupt(6));
  add(corrupt(7));
  add(good(8));
  add(good(9));
  std::vector<DeviceFrame> frames;
  for (size_t at = 0; at < stream.size(); at += 5) {
    d->Feed(stream.data() + at, std::min<size_t>(5, stream.size() - at), &frames);
  }
  ASSERT_EQ(frames.size(), 6u);
  const int want_value[] = {0, 1, 3, 5, 8, 9};
  const int64_t want_rejected[] = {0, 0, 1, 1, 2, 0};
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_FLOAT_EQ(frames[i].values[0], want_value[i] * 300.0f / 32767) << i;
    EXPECT_EQ(frames[i].rejected_before, want_rejected[i]) << i;
  }
}

TEST(CrossbowDecoderTest, RangesAreRequiredAndKeysBelongToTheProtocol) {
  for (const auto& [text, says] : std::vector<std::pair<std::string, std::string>>{
           {"serial:/dev/null,protocol=crossbow,rate=100,duration=1", "give rate_range="},
           {"serial:/dev/null,protocol=crossbow,rate=100,duration=1,rate_range=200,"
            "axes=gx:gyro/ax:accel",
            "give g_range="},
           {"serial:/dev/null,protocol=crossbow,rate=100,duration=1,rate_range=200,checksum=xor",
            "checksum=xor must be mod256, mod255 or either"},
           {"serial:/dev/null,protocol=xsens,rate=100,duration=1,rate_range=200",
            "'rate_range' is for protocol=crossbow"}}) {
    auto spec = ParseSourceSpec(text);
    ASSERT_TRUE(spec.ok()) << text;
    auto source = MakeSource(*spec, SourceDefaults{});
    ASSERT_FALSE(source.ok()) << text;
    EXPECT_NE(source.status().message().find(says), std::string::npos)
        << text << ": " << source.status().message();
  }
}

// A VG700 on a pseudo-terminal: the source decodes its packets in real time.
TEST(CrossbowDecoderTest, AUnitOnASerialLine) {
  testing::TempDir dir("crossbow_pty");
  testing::PtyDevice dev(dir.path("vg700"));
  auto spec = ParseSourceSpec("serial:" + dev.path() +
                              ",protocol=crossbow,baud=38400,rate=100,duration=0.3,"
                              "rate_range=200,checksum=mod255");
  ASSERT_TRUE(spec.ok());
  auto source = MakeSource(*spec, SourceDefaults{});
  ASSERT_TRUE(source.ok()) << source.status().message();
  std::string bytes;
  for (int k = 0; k < 60; ++k) {
    const auto p = Packet({static_cast<int16_t>(100 * k), -5, 7, 0, 0, 16384}, 1126,
                          static_cast<uint16_t>(k), CrossbowChecksum::kMod255);
    bytes.append(p.begin(), p.end());
  }
  // All at once: early arrivals keep their order; a writer stalled by a
  // loaded machine could otherwise look like lost output to the host clock.
  ASSERT_TRUE(dev.Write(bytes));
  std::vector<float> gx;
  const double deadline = MonotonicSeconds() + 20;
  while (gx.size() < 30 && MonotonicSeconds() < deadline) {
    SampleBlock b;
    auto n = (*source)->Read(64, &b);
    ASSERT_TRUE(n.ok()) << n.status().message();
    if (*n == 0) break;
    if (*n == kNoSamplesYet) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    for (int i = 0; i < *n; ++i) gx.push_back(b.samples[0][i]);
  }
  // THEN 30 samples (0.3 s at 100 Hz), packet k's roll rate in order.
  ASSERT_EQ(gx.size(), 30u);
  for (int k = 0; k < 30; ++k) {
    EXPECT_FLOAT_EQ(gx[k], static_cast<float>(100 * k * 300.0 / 32767)) << k;
  }
}

}  // namespace
}  // namespace imuqual::acquire
