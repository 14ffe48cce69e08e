// SerialSource against a pseudo-terminal: the device timeline (counter
// wrap, duplicates, a device restart, unplug and replug), blocks cut at
// jumps, the end by duration, and the errors a missing or wrong device gets.
// Waits are bounded; nothing asserts a wall-clock time.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <thread>

#include "acquire/serial_source.h"
#include "acquire/text_protocol.h"
#include "common/clock.h"
#include "tests/pty_device.h"
#include "tests/test_util.h"

namespace imuqual::acquire {
namespace {

using testing::PtyDevice;
using testing::TempDir;

struct Sample {
  int64_t counter;
  float value;
};

std::unique_ptr<FrameDecoder> CountAndGx(int counter_bits) {
  TextProtocolOptions t;
  t.columns = {"n", "gx"};
  t.axes = {"gx"};
  t.counter_column = "n";
  t.counter_bits = counter_bits;
  auto d = TextLineDecoder::Create(t);
  return std::move(*d);
}

SerialSourceOptions Options(const std::string& device, double rate_hz, double duration_s) {
  SerialSourceOptions o;
  o.port.device = device;
  o.protocol = "text";
  pb::Axis gx;
  gx.set_name("gx");
  o.axes = {gx};
  o.rate_hz = rate_hz;
  o.duration_s = duration_s;
  o.max_latency_s = 0.05;
  return o;
}

// Reads blocks until `want` samples arrived, the source ends or fails, or
// `timeout_s` passes. Every block's samples are consecutive by construction;
// the test checks the counters across blocks.
Status Collect(SerialSource& s, size_t want, double timeout_s, std::vector<Sample>* out,
               std::vector<int64_t>* block_starts = nullptr) {
  const double deadline = MonotonicSeconds() + timeout_s;
  while (out->size() < want && MonotonicSeconds() < deadline) {
    SampleBlock b;
    auto n = s.Read(64, &b);
    if (!n.ok()) return n.status();
    if (*n == 0) return Status::Ok();
    if (*n == kNoSamplesYet) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    EXPECT_GT(b.first_sample_utime, 0);
    if (block_starts) block_starts->push_back(b.first_sample);
    for (int i = 0; i < *n; ++i) out->push_back({b.first_sample + i, b.samples[0][i]});
  }
  return Status::Ok();
}

std::string Line(uint64_t counter, double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%llu,%g\n", static_cast<unsigned long long>(counter), value);
  return buf;
}

// Writes `lines` in real time, line k due at t0 + k / rate_hz.
void WritePaced(PtyDevice& dev, const std::vector<std::string>& lines, double rate_hz) {
  const double t0 = MonotonicSeconds();
  size_t k = 0;
  while (k < lines.size()) {
    std::string chunk;
    while (k < lines.size() && static_cast<double>(k) / rate_hz <= MonotonicSeconds() - t0) chunk += lines[k++];
    if (!chunk.empty()) {
      ASSERT_TRUE(dev.Write(chunk));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

TEST(SerialSourceTest, EightBitCounterUnwrapsAcrossWrapsInRealTime) {
  TempDir dir("serial_wrap");
  PtyDevice dev(dir.path("imu"));
  auto src = SerialSource::Open(Options(dev.path(), 1000, 100), CountAndGx(8));
  ASSERT_TRUE(src.ok()) << src.status().message();
  ASSERT_TRUE(dev.Write("\n"));  // the first line may be partial: start clean
  std::vector<std::string> lines;
  for (int k = 0; k < 700; ++k) lines.push_back(Line((200 + k) % 256, k * 0.5));
  WritePaced(dev, lines, 1000);
  std::vector<Sample> got;
  ASSERT_TRUE(Collect(**src, 700, 10, &got).ok());
  ASSERT_EQ(got.size(), 700u);
  for (int k = 0; k < 700; ++k) {
    ASSERT_EQ(got[k].counter, 200 + k) << k;
    EXPECT_EQ(got[k].value, static_cast<float>(k * 0.5)) << k;
  }
  EXPECT_EQ((*src)->counters().counter_rebases, 0);
}

TEST(SerialSourceTest, UnplugLongerThanSeveralWrapsLandsOnTheRightWrap) {
  TempDir dir("serial_wraps_unplug");
  PtyDevice dev(dir.path("imu"));
  auto src = SerialSource::Open(Options(dev.path(), 1000, 100), CountAndGx(8));
  ASSERT_TRUE(src.ok());
  ASSERT_TRUE(dev.Write("\n"));
  // The device counts on at 1000 Hz while unplugged: 256-sample wraps, so
  // an unplug of ~0.9 s hides three or four of them.
  const double t0 = MonotonicSeconds();
  auto line_at = [&](int64_t k) { return Line(k % 256, static_cast<double>(k)); };
  std::vector<std::string> before;
  for (int k = 0; k < 200; ++k) before.push_back(line_at(k));
  WritePaced(dev, before, 1000);
  std::vector<Sample> got;
  ASSERT_TRUE(Collect(**src, 200, 10, &got).ok());
  dev.Unplug();
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  dev.Plug();
  const double deadline = MonotonicSeconds() + 10;
  while ((*src)->counters().reconnects < 1 && MonotonicSeconds() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_EQ((*src)->counters().reconnects, 1);
  // The device's counter now: the samples it made since t0.
  const int64_t resume = static_cast<int64_t>((MonotonicSeconds() - t0) * 1000);
  std::vector<std::string> after = {"\n"};
  for (int64_t k = resume; k < resume + 100; ++k) after.push_back(line_at(k));
  WritePaced(dev, after, 1000);
  std::vector<Sample> later;
  ASSERT_TRUE(Collect(**src, 100, 10, &later).ok());
  ASSERT_EQ(later.size(), 100u);
  for (int i = 0; i < 100; ++i) {
    // The value is the device's own sample number: the timeline must agree.
    EXPECT_EQ(later[i].counter, static_cast<int64_t>(later[i].value)) << i;
  }
  EXPECT_EQ(later[0].counter, resume);
  EXPECT_EQ((*src)->counters().counter_rebases, 0);
}

TEST(SerialSourceTest, DeviceRestartedWhileUnpluggedIsRebasedOnTheHostClock) {
  TempDir dir("serial_restart_unplug");
  PtyDevice dev(dir.path("imu"));
  auto src = SerialSource::Open(Options(dev.path(), 1000, 100), CountAndGx(16));
  ASSERT_TRUE(src.ok());
  std::vector<std::string> lines = {"\n"};
  for (int k = 0; k < 300; ++k) lines.push_back(Line(1000 + k, k));
  WritePaced(dev, lines, 1000);
  std::vector<Sample> got;
  ASSERT_TRUE(Collect(**src, 300, 10, &got).ok());
  const int64_t last = got.back().counter;  // 1299
  const double unplugged = MonotonicSeconds();
  dev.Unplug();
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  dev.Plug();
  const double deadline = MonotonicSeconds() + 10;
  while ((*src)->counters().reconnects < 1 && MonotonicSeconds() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  // Powered again, it counts from 50: a step of 1300 samples back... or,
  // read as 16 bits, forward 64286. Neither fits ~1 s of host time.
  const double gone_s = MonotonicSeconds() - unplugged;
  lines = {"\n"};
  for (int k = 0; k < 50; ++k) lines.push_back(Line(50 + k, 5000 + k));
  WritePaced(dev, lines, 1000);
  got.clear();
  ASSERT_TRUE(Collect(**src, 50, 10, &got).ok());
  ASSERT_EQ(got.size(), 50u);
  EXPECT_EQ((*src)->counters().counter_rebases, 1);
  // Placed where the host clock says: about gone_s of samples after the last.
  EXPECT_NEAR(static_cast<double>(got[0].counter - last), gone_s * 1000, 300);
  for (int k = 1; k < 50; ++k) EXPECT_EQ(got[k].counter, got[0].counter + k);
}

TEST(SerialSourceTest, RejectedLinesOfACounterlessDeviceKeepTheirPlace) {
  TempDir dir("serial_counterless");
  PtyDevice dev(dir.path("imu"));
  TextProtocolOptions t;
  t.columns = {"gx"};
  t.axes = {"gx"};
  auto decoder = TextLineDecoder::Create(t);
  ASSERT_TRUE(decoder.ok());
  auto src = SerialSource::Open(Options(dev.path(), 1000, 100), std::move(*decoder));
  ASSERT_TRUE(src.ok());
  // Lines 0..9, with 3, 4 and 7 garbled on the line (a blank line is
  // nothing at all).
  ASSERT_TRUE(dev.Write("\n0\n1\n2\nx3\n4,4\n5\n6\n\n7.7.7\n8\n9\n"));
  std::vector<Sample> got;
  ASSERT_TRUE(Collect(**src, 7, 10, &got).ok());
  ASSERT_EQ(got.size(), 7u);
  for (const Sample& s : got) EXPECT_EQ(s.counter, static_cast<int64_t>(s.value)) << s.value;
}

TEST(SerialSourceTest, JumpsCutBlocksDuplicatesDropAndARestartIsRebased) {
  TempDir dir("serial_jumps");
  PtyDevice dev(dir.path("imu"));
  auto src = SerialSource::Open(Options(dev.path(), 1000, 100), CountAndGx(0));
  ASSERT_TRUE(src.ok());
  std::string text = "\n";
  for (int k = 0; k < 10; ++k) text += Line(100 + k, k);
  text += Line(109, 99);                                    // the same sample again
  for (int k = 15; k < 20; ++k) text += Line(100 + k, k);   // 5 samples lost on the device
  ASSERT_TRUE(dev.Write(text));
  std::vector<Sample> got;
  std::vector<int64_t> starts;
  ASSERT_TRUE(Collect(**src, 15, 10, &got, &starts).ok());
  ASSERT_EQ(got.size(), 15u);
  EXPECT_EQ(got[9].counter, 109);
  EXPECT_EQ(got[9].value, 9.0f);    // the first of the duplicates is kept
  EXPECT_EQ(got[10].counter, 115);  // a gap of 5, a new block
  EXPECT_NE(std::find(starts.begin(), starts.end(), 115), starts.end());
  EXPECT_EQ((*src)->counters().duplicate_frames, 1);
  EXPECT_EQ((*src)->counters().counter_rebases, 0);

  // The device restarts: its counter goes back to 0. The timeline goes on
  // from the host clock, after the last sample.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  text.clear();
  for (int k = 0; k < 10; ++k) text += Line(k, 1000 + k);
  ASSERT_TRUE(dev.Write(text));
  got.clear();
  ASSERT_TRUE(Collect(**src, 10, 10, &got).ok());
  ASSERT_EQ(got.size(), 10u);
  // 200 ms of host time after the last sample (at 1000 Hz), give or take
  // the scheduler.
  EXPECT_GT(got[0].counter, 119 + 150);
  EXPECT_LT(got[0].counter, 119 + 1000);
  for (int k = 1; k < 10; ++k) EXPECT_EQ(got[k].counter, got[0].counter + k);
  EXPECT_EQ(got[0].value, 1000.0f);
  EXPECT_EQ((*src)->counters().counter_rebases, 1);
}

TEST(SerialSourceTest, EndsAfterItsDurationOfDeviceTime) {
  TempDir dir("serial_end");
  PtyDevice dev(dir.path("imu"));
  auto src = SerialSource::Open(Options(dev.path(), 100, 0.5), CountAndGx(0));  // 50 samples
  ASSERT_TRUE(src.ok());
  std::string text = "\n";
  for (int k = 0; k < 80; ++k) text += Line(k, k);
  ASSERT_TRUE(dev.Write(text));
  std::vector<Sample> got;
  ASSERT_TRUE(Collect(**src, 1000, 10, &got).ok());
  EXPECT_EQ(got.size(), 50u);
  SampleBlock b;
  auto n = (*src)->Read(64, &b);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 0);
}

TEST(SerialSourceTest, ADeviceGoneLongerThanTheTimeoutFailsNamingIt) {
  TempDir dir("serial_gone");
  PtyDevice dev(dir.path("imu"));
  SerialSourceOptions o = Options(dev.path(), 100, 100);
  o.reconnect_timeout_s = 0.5;
  auto src = SerialSource::Open(o, CountAndGx(0));
  ASSERT_TRUE(src.ok());
  ASSERT_TRUE(dev.Write("\n" + Line(0, 1) + Line(1, 2)));
  std::vector<Sample> got;
  ASSERT_TRUE(Collect(**src, 2, 10, &got).ok());
  ASSERT_EQ(got.size(), 2u);  // what arrived is delivered
  dev.Unplug();
  Status st = Collect(**src, 100, 10, &got);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find(dev.path()), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("gone"), std::string::npos) << st.message();
}

TEST(SerialSourceTest, MissingDeviceOrNotATerminalIsAnErrorAtOpen) {
  TempDir dir("serial_open");
  auto missing = SerialSource::Open(Options(dir.path("nothing"), 100, 1), CountAndGx(0));
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("nothing"), std::string::npos);
  std::ofstream(dir.path("file")) << "x";
  auto file = SerialSource::Open(Options(dir.path("file"), 100, 1), CountAndGx(0));
  ASSERT_FALSE(file.ok());
  EXPECT_NE(file.status().message().find("not a terminal"), std::string::npos);
  SerialSourceOptions bad = Options(dir.path("file"), 100, 1);
  bad.port.baud = 12345;
  auto baud = SerialSource::Open(bad, CountAndGx(0));
  ASSERT_FALSE(baud.ok());
  EXPECT_NE(baud.status().message().find("12345"), std::string::npos);
}

}  // namespace
}  // namespace imuqual::acquire
