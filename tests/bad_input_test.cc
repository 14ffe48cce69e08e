// Bad input never crashes a process or costs accepted data: garbage,
// foreign and lying messages on every channel, a run full of invalid
// samples and out-of-order, duplicate, absurd or inconsistent batches, files
// that are not archives, an unwritable directory and a full disk. Each gets
// a clear error or a counted rejection.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include "common/batch_integrity.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/strings.h"
#include "common/text_util.h"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/status_t.hpp"
#include "store/archive.h"
#include "store/chunk_codec.h"
#include "store/query.h"
#include "store/store_service.h"
#include "tests/station_harness.h"

namespace imuqual {
namespace {

using testing::Bin;
using testing::RunCommand;
using testing::StationHarness;

constexpr double kRateHz = 100;
constexpr int kSamples = 50;  // per batch

// Plays acquire: announces a 3-axis gyro run and publishes batches.
class FakeAcquire {
 public:
  FakeAcquire(StationHarness& h, std::string run_id, std::string serial)
      : h_(h), serial_(std::move(serial)) {
    run_.host_utime = NowUtime();
    run_.run_id = std::move(run_id);
    run_.unit_serial = serial_;
    run_.lot = "BAD";
    run_.station = "test";
    run_.source = "fake";
    run_.start_utime = NowUtime();
    run_.nominal_rate_hz = kRateHz;
    run_.num_axes = 3;
    run_.axis_names = {"x", "y", "z"};
    run_.axis_kinds = {1, 1, 1};
    pb::TestPlan plan;
    plan.set_nominal_rate_hz(kRateHz);
    const std::string bytes = plan.SerializeAsString();
    run_.plan_size = static_cast<int32_t>(bytes.size());
    run_.plan.assign(bytes.begin(), bytes.end());
    run_.plan_sha256 = Sha256Hex(bytes);
    run_.truth_size = 0;
    run_.state = imuqual::run_t::STATE_RUNNING;
    run_.last_seq = -1;
    run_.samples_published = 0;
    run_.first_sample = -1;
    run_.end_sample = -1;
    run_.announcer = "acquire";
    run_.retained_first_seq = 0;
    run_.revision = 0;
  }

  void Announce(int8_t state, int64_t last_seq, int64_t samples) {
    run_.host_utime = NowUtime();
    run_.state = state;
    run_.last_seq = last_seq;
    run_.samples_published = samples;
    run_.first_sample = samples > 0 ? 0 : -1;
    run_.end_sample = samples > 0 ? samples : -1;
    ASSERT_TRUE(h_.BusAs(BusRole::kAcquire).Publish(channels::kRun, run_).ok());
  }

  imuqual::rate_batch_t Batch(int64_t seq, int64_t first_sample) const {
    imuqual::rate_batch_t b;
    b.host_utime = NowUtime();
    b.run_id = run_.run_id;
    b.unit_serial = serial_;
    b.seq = seq;
    b.first_sample = first_sample;
    b.nominal_rate_hz = kRateHz;
    b.num_axes = 3;
    b.axis_names = run_.axis_names;
    b.axis_kinds = run_.axis_kinds;
    b.num_samples = kSamples;
    for (int a = 0; a < 3; ++a) {
      std::vector<float> v;
      for (int i = 0; i < kSamples; ++i) {
        v.push_back(0.01f * static_cast<float>(std::sin(0.37 * (first_sample + i) + a)));
      }
      b.samples.push_back(v);
    }
    b.num_flagged = 0;
    b.has_temperature = 0;
    b.temperature_c = 0;
    return b;
  }

  // Seals (checksum) and publishes, as acquire does.
  void Send(imuqual::rate_batch_t b) { SendBytes(Sealed(&b)); }
  // The sealed encoding of `b`.
  static std::vector<uint8_t> Sealed(imuqual::rate_batch_t* b) {
    std::vector<uint8_t> bytes;
    EXPECT_TRUE(EncodeSealedBatch(b, &bytes).ok());
    return bytes;
  }
  void SendBytes(const std::vector<uint8_t>& bytes) {
    ASSERT_TRUE(h_.BusAs(BusRole::kAcquire).PublishEncoded(channels::Raw(serial_), bytes).ok());
  }

 private:
  StationHarness& h_;
  std::string serial_;
  imuqual::run_t run_;
};

// Bytes of a valid rate_batch_t with its num_samples field overwritten.
std::vector<uint8_t> LyingBatch(const imuqual::rate_batch_t& b, int16_t claimed_samples) {
  std::vector<uint8_t> bytes;
  EXPECT_TRUE(EncodeMessage(b, &bytes).ok());
  // LCM layout: fingerprint 8, host_utime 8, two strings (4-byte length,
  // bytes, NUL), seq 8, first_sample 8, rate 8, num_axes 1, names, kinds,
  // then num_samples as a big-endian int16.
  size_t off = 8 + 8 + (4 + b.run_id.size() + 1) + (4 + b.unit_serial.size() + 1) + 8 + 8 + 8 + 1;
  for (const std::string& n : b.axis_names) off += 4 + n.size() + 1;
  off += b.axis_names.size();
  bytes[off] = static_cast<uint8_t>(static_cast<uint16_t>(claimed_samples) >> 8);
  bytes[off + 1] = static_cast<uint8_t>(claimed_samples & 0xff);
  return bytes;
}

TEST(BadInputTest, GarbageForeignAndLyingMessagesAreCountedAndTheRunSurvivesIt) {
  StationHarness h("bad_messages");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  FakeAcquire acq(h, "BADRUN-1", "BAD-U01");
  acq.Announce(imuqual::run_t::STATE_RUNNING, -1, 0);

  // Undecodable bytes on every channel the station uses.
  const std::vector<std::string> channels_used = {channels::kRun,
                                                  channels::kAck,
                                                  channels::kResend,
                                                  channels::kStatus,
                                                  channels::Raw("BAD-U01"),
                                                  channels::Curve("BAD-U01"),
                                                  channels::Result("BAD-U01")};
  for (const std::string& ch : channels_used) {
    for (size_t n : {size_t{0}, size_t{3}, size_t{64}, size_t{1000}}) {
      std::vector<uint8_t> junk(n);
      for (size_t i = 0; i < n; ++i) junk[i] = static_cast<uint8_t>(i * 37 + 11);
      // Sealed by a role that may speak there: junk past the seal, for the decoder.
      const BusRole role = PolicyOf(ch).Allows(BusRole::kAcquire)  ? BusRole::kAcquire
                           : PolicyOf(ch).Allows(BusRole::kStore) ? BusRole::kStore
                                                                   : BusRole::kAnalyze;
      ASSERT_TRUE(h.BusAs(role).PublishEncoded(ch, junk).ok());
    }
  }
  // A wrong type (fingerprint) on the raw and run channels.
  imuqual::status_t foreign;
  foreign.host_utime = 1;
  foreign.process = "x";
  foreign.instance = "y";
  foreign.healthy = 1;
  foreign.num_counters = 0;
  ASSERT_TRUE(h.BusAs(BusRole::kAcquire).Publish(channels::Raw("BAD-U01"), foreign).ok());
  ASSERT_TRUE(h.BusAs(BusRole::kAcquire).Publish(channels::kRun, foreign).ok());
  // Length fields that lie: more samples than the bytes hold, and negative.
  for (int16_t lie : {int16_t{30000}, int16_t{-5}, int16_t{kSamples + 1}}) {
    ASSERT_TRUE(
        h.BusAs(BusRole::kAcquire).PublishEncoded(channels::Raw("BAD-U01"), LyingBatch(acq.Batch(0, 0), lie)).ok());
  }

  // The run itself: 40 batches with everything wrong that can be wrong.
  int64_t counter = 0, invalid = 0;
  std::vector<imuqual::rate_batch_t> batches;
  for (int64_t seq = 0; seq < 40; ++seq, counter += kSamples) {
    imuqual::rate_batch_t b = acq.Batch(seq, counter);
    if (seq == 3) {  // NaN and infinities
      b.samples[0][1] = std::numeric_limits<float>::quiet_NaN();
      b.samples[1][2] = std::numeric_limits<float>::infinity();
      b.samples[2][3] = -std::numeric_limits<float>::infinity();
      invalid += 3;
    }
    if (seq == 4) {  // saturated and invalid flags
      b.num_flagged = 2;
      b.flagged_sample = {5, 6};
      b.flagged_axis = {0, 2};
      b.flagged_bits = {imuqual::rate_batch_t::FLAG_SATURATED, imuqual::rate_batch_t::FLAG_INVALID};
      invalid += 2;
    }
    batches.push_back(b);
  }
  // seq 20 claims another rate; seq 30's counter goes backwards.
  batches[20].nominal_rate_hz = 200;
  batches[30].first_sample = batches[29].first_sample;
  for (int64_t seq = 0; seq < 40; ++seq) {
    if (seq == 10) continue;  // sent late: out of order
    acq.Send(batches[seq]);
    if (seq == 12) acq.Send(batches[10]);
    if (seq == 15) acq.Send(batches[15]);  // duplicate
  }
  imuqual::rate_batch_t absurd = acq.Batch(int64_t{1} << 40, 0);
  acq.Send(absurd);
  acq.Announce(imuqual::run_t::STATE_COMPLETE, 39, counter);
  // Nobody resends the rejected seq 20: it becomes a gap after give-up.
  for (int i = 0; i < 3; ++i) {
    h.Pump(300);
    acq.Announce(imuqual::run_t::STATE_COMPLETE, 39, counter);
  }
  ASSERT_TRUE(h.WaitRunsDone(1, 60)) << h.Logs();

  // Counted, not crashed.
  EXPECT_GT(h.WaitCounter("store", "decode_errors", 20, 5), 20);
  EXPECT_GT(h.WaitCounter("analyze", "decode_errors", 10, 5), 10);
  EXPECT_GE(h.WaitCounter("store", "duplicates", 1, 5), 1);
  EXPECT_GE(h.WaitCounter("store", "absurd_seq", 1, 5), 1);
  EXPECT_GE(h.WaitCounter("store", "rejected", 1, 5), 1);
  EXPECT_GE(h.WaitCounter("analyze", "duplicates", 1, 5), 1);
  EXPECT_GE(h.WaitCounter("analyze", "absurd_seq", 1, 5), 1);
  EXPECT_GE(h.WaitCounter("analyze", "rejected", 2, 5), 2);  // the rate and the backwards counter
  EXPECT_FALSE(store.Poll().has_value()) << h.Logs();
  EXPECT_FALSE(analyze.Poll().has_value()) << h.Logs();

  auto a = store::Archive::Open(h.db(), store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  const int64_t key = **(*a)->FindRunKey("BADRUN-1");
  std::vector<int64_t> seqs;
  ASSERT_TRUE((*a)->ForEachChunk(key,
                                 [&](const store::ChunkRecord& c) {
                                   seqs.push_back(c.seq);
                                   if (c.seq == 3) {  // archived exactly as sent, NaN included
                                     auto d = store::DecodeChunk(c.data, c.codec);
                                     EXPECT_TRUE(std::isnan(d->at(0, 1)));
                                     EXPECT_TRUE(std::isinf(d->at(1, 2)));
                                   }
                                   if (c.seq == 4) {
                                     auto d = store::DecodeChunk(c.data, c.codec);
                                     EXPECT_EQ(d->flags.size(), 2u);
                                   }
                                   return Status::Ok();
                                 })
                  .ok());
  EXPECT_EQ(seqs.size(), 39u);  // all but the wrong-rate batch
  EXPECT_EQ(std::count(seqs.begin(), seqs.end(), 20), 0);
  // The archive records what is wrong with it: seq 20 never archived, the
  // counter going back at 30, and the samples batch 30 should have held.
  auto gaps = (*a)->LoadGaps(key);
  ASSERT_EQ(gaps->size(), 3u);
  EXPECT_EQ((*gaps)[0].first_seq, 20);
  EXPECT_EQ((*gaps)[0].reason, "seq");
  EXPECT_EQ((*gaps)[1].reason, "counter_backwards");
  EXPECT_EQ((*gaps)[1].num_samples.value(), -kSamples);
  EXPECT_EQ((*gaps)[2].reason, "counter");
  EXPECT_EQ((*gaps)[2].num_samples.value(), kSamples);
  auto s = (*a)->db().Prepare(
      "SELECT invalid_samples, gap_samples, verdict FROM runs WHERE run_key = ?");
  s->Bind(1, key);
  ASSERT_TRUE(*s->Step());
  EXPECT_EQ(s->Int(0), invalid);
  // The wrong-rate batch and the backwards one are missing from the analysis.
  EXPECT_GE(s->Int(1), kSamples);
  // Each axis counts its own: x the NaN and the saturated one, y the
  // infinity, z the -infinity and the invalid one.
  auto axes = (*a)->db().Prepare(
      "SELECT axis, invalid_samples FROM axis_results WHERE run_key = ? ORDER BY axis_index");
  axes->Bind(1, key);
  std::map<std::string, int64_t> per_axis;
  while (*axes->Step()) per_axis[axes->Text(0)] = axes->Int(1);
  EXPECT_EQ(per_axis, (std::map<std::string, int64_t>{{"x", 2}, {"y", 1}, {"z", 2}}));

  EXPECT_EQ(analyze.Stop(15), 0);
  EXPECT_EQ(store.Stop(15), 0);
}

// Byte offset of samples[0][0] in the encoding of `b` (see LyingBatch).
size_t SamplesOffset(const imuqual::rate_batch_t& b) {
  size_t off = 8 + 8 + (4 + b.run_id.size() + 1) + (4 + b.unit_serial.size() + 1) + 8 + 8 + 8 + 1;
  for (const std::string& n : b.axis_names) off += 4 + n.size() + 1;
  return off + b.axis_names.size() + 2;
}

TEST(BadInputTest, DamagedBatchesAreCountedDroppedAndResentNeverArchivedOrAnalysed) {
  StationHarness h("bad_damaged");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  FakeAcquire acq(h, "DMGRUN-1", "DMG-U01");
  acq.Announce(imuqual::run_t::STATE_RUNNING, -1, 0);
  constexpr int kBatches = 12;
  std::vector<imuqual::rate_batch_t> batches;
  for (int64_t seq = 0; seq < kBatches; ++seq) batches.push_back(acq.Batch(seq, seq * kSamples));
  // GIVEN two batches each with one bit flipped on the way, after acquire
  // sealed them: an exponent bit of a sample (decodes to a plausible batch
  // with one wild value), and a bit of the run id ("DMGRUN-1" -> "EMGRUN-1").
  std::vector<uint8_t> sample_flip = FakeAcquire::Sealed(&batches[4]);
  sample_flip[SamplesOffset(batches[4]) + 4 * 7] ^= 0x40;
  std::vector<uint8_t> id_flip = FakeAcquire::Sealed(&batches[7]);
  id_flip[8 + 8 + 4] ^= 0x01;
  // WHEN the run is sent with those in place of the originals
  for (int64_t seq = 0; seq < kBatches; ++seq) {
    if (seq == 4) {
      acq.SendBytes(sample_flip);
    } else if (seq == 7) {
      acq.SendBytes(id_flip);
    } else {
      acq.Send(batches[seq]);
    }
  }
  // THEN both consumers count both and ask for them again
  EXPECT_EQ(h.WaitCounter("store", "batches_damaged", 2, 10), 2) << h.Logs();
  EXPECT_EQ(h.WaitCounter("analyze", "batches_damaged", 2, 10), 2) << h.Logs();
  EXPECT_GE(h.WaitCounter("store", "resend_requests", 1, 10), 1) << h.Logs();
  EXPECT_GE(h.WaitCounter("analyze", "resend_requests", 1, 10), 1) << h.Logs();
  // AND the resent originals complete the run with nothing damaged in it.
  acq.Send(batches[4]);
  acq.Send(batches[7]);
  acq.Announce(imuqual::run_t::STATE_COMPLETE, kBatches - 1, kBatches * kSamples);
  for (int i = 0; i < 3; ++i) {
    h.Pump(300);
    acq.Announce(imuqual::run_t::STATE_COMPLETE, kBatches - 1, kBatches * kSamples);
  }
  ASSERT_TRUE(h.WaitRunsDone(1, 60)) << h.Logs();
  auto a = store::Archive::Open(h.db(), store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  auto runs = (*a)->db().QueryInt("SELECT COUNT(*) FROM runs");
  EXPECT_EQ(*runs, 1);  // no run made up from the damaged id
  const int64_t key = **(*a)->FindRunKey("DMGRUN-1");
  int64_t chunks = 0;
  ASSERT_TRUE((*a)->ForEachChunk(key,
                                 [&](const store::ChunkRecord& c) {
                                   ++chunks;
                                   auto d = store::DecodeChunk(c.data, c.codec);
                                   EXPECT_TRUE(d.ok());
                                   if (d.ok() && c.seq == 4) {
                                     EXPECT_EQ(d->at(0, 7), batches[4].samples[0][7]);
                                   }
                                   return Status::Ok();
                                 })
                  .ok());
  EXPECT_EQ(chunks, kBatches);
  EXPECT_TRUE((*a)->LoadGaps(key)->empty());
  auto gap = (*a)->db().Prepare("SELECT gap_samples FROM runs WHERE run_key = ?");
  gap->Bind(1, key);
  ASSERT_TRUE(*gap->Step());
  EXPECT_EQ(gap->Int(0), 0);  // analysed whole: the resent batches, not holes
  EXPECT_EQ(analyze.Stop(15), 0);
  EXPECT_EQ(store.Stop(15), 0);
}

// One column of `imuqual lot --format csv` output by axis (axis -> cell).
std::map<std::string, std::string> LotColumnByAxis(const std::string& csv,
                                                   const std::string& column) {
  std::map<std::string, std::string> by_axis;
  std::istringstream rows(csv);
  std::string line;
  std::getline(rows, line);
  const std::vector<std::string> header = Split(line, ',');
  const size_t axis_col = std::find(header.begin(), header.end(), "axis") - header.begin();
  const size_t col = std::find(header.begin(), header.end(), column) - header.begin();
  if (axis_col >= header.size() || col >= header.size()) {
    ADD_FAILURE() << "no column axis or " << column << " in: " << line;
    return by_axis;
  }
  while (std::getline(rows, line)) {
    const std::vector<std::string> cells = Split(line, ',');
    if (cells.size() != header.size()) {
      ADD_FAILURE() << cells.size() << " cells for " << header.size() << " columns: " << line;
      continue;
    }
    by_axis[cells[axis_col]] = cells[col];
  }
  return by_axis;
}

TEST(BadInputTest, InvalidSamplesOnOneAxisAreReportedOnThatAxisOnly) {
  StationHarness h("bad_one_axis");
  Subprocess store = h.StartStore();
  Subprocess analyze = h.StartAnalyze();
  // GIVEN a run whose y axis alone has NaN samples and flagged ones
  FakeAcquire acq(h, "ONEAXIS-1", "BAD-U02");
  acq.Announce(imuqual::run_t::STATE_RUNNING, -1, 0);
  constexpr int64_t kBatches = 20;
  int64_t invalid_y = 0;
  for (int64_t seq = 0; seq < kBatches; ++seq) {
    imuqual::rate_batch_t b = acq.Batch(seq, seq * kSamples);
    if (seq % 4 == 1) {
      b.samples[1][0] = std::numeric_limits<float>::quiet_NaN();
      b.samples[1][7] = std::numeric_limits<float>::quiet_NaN();
      invalid_y += 2;
    }
    if (seq == 6) {
      b.num_flagged = 1;
      b.flagged_sample = {9};
      b.flagged_axis = {1};
      b.flagged_bits = {imuqual::rate_batch_t::FLAG_SATURATED};
      invalid_y += 1;
    }
    acq.Send(b);
  }
  for (int i = 0; i < 3; ++i) {
    acq.Announce(imuqual::run_t::STATE_COMPLETE, kBatches - 1, kBatches * kSamples);
    h.Pump(200);
  }
  ASSERT_TRUE(h.WaitRunsDone(1, 60)) << h.Logs();
  // WHEN the lot is listed per unit and axis
  const auto lot = RunCommand(Bin("imuqual") + " lot BAD --db " + h.db() + " --format csv");
  ASSERT_EQ(lot.exit_code, 0) << lot.output;
  // THEN y carries its invalid samples and x and z none (not the run's total on each)
  const std::map<std::string, std::string> invalid_of =
      LotColumnByAxis(lot.output, "invalid_samples");
  EXPECT_EQ(invalid_of, (std::map<std::string, std::string>{
                            {"x", "0"}, {"y", std::to_string(invalid_y)}, {"z", "0"}}))
      << lot.output;
  // AND the run's own figure is still the total, over the axes
  auto a = store::Archive::Open(h.db(), store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok());
  auto total = (*a)->db().QueryInt("SELECT invalid_samples FROM runs WHERE run_id = 'ONEAXIS-1'");
  ASSERT_TRUE(total.ok());
  EXPECT_EQ(*total, invalid_y);
  EXPECT_EQ(analyze.Stop(15), 0);
  EXPECT_EQ(store.Stop(15), 0);
}

TEST(BadInputTest, FilesThatAreNotArchivesGetAOneLineErrorAndAreNotTouched) {
  testing::TempDir dir("bad_files");
  const std::string text = dir.path("notes.txt");
  { std::ofstream(text) << "these are notes, not an archive; please leave them alone\n"; }
  for (const std::string& cmd :
       {Bin("imuqual-store") + " --lcm-url 'udpm://239.255.76.67:7999?ttl=0' --db " + text,
        Bin("imuqual") + " lots --db " + text, Bin("imuqual") + " lot X --db " + text,
        Bin("imuqual") + " lots --db " + dir.path("missing.db"),
        Bin("imuqual-store") + " --lcm-url 'udpm://239.255.76.67:7999?ttl=0' --db " +
            dir.path("no/such/dir/a.db")}) {
    const auto r = RunCommand(cmd + " 2>&1");
    EXPECT_NE(r.exit_code, 0) << cmd;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << cmd << ":\n" << r.output;
  }
  auto after = ReadFileToString(text);
  EXPECT_EQ(*after, "these are notes, not an archive; please leave them alone\n");
}

// The lines of a command's output that say "error".
int ErrorLines(const std::string& output) {
  int n = 0;
  for (size_t at = output.find("error:"); at != std::string::npos;
       at = output.find("error:", at + 1)) {
    ++n;
  }
  return n;
}

TEST(BadInputTest, ARateThatIsNoRateIsRefusedByEveryCommandThatTakesIt) {
  testing::TempDir dir("bad_rate");
  const std::string db = dir.path("rate.db");
  const std::string bus = "'udpm://239.255.76.67:7997?ttl=0'";
  for (const std::string rate : {"0", "-5", "nan", "inf"}) {
    for (const std::string& cmd :
         {Bin("imuqual-acquire") + " --lcm-url " + bus + " --lot L --sim 1 --duration 10 --rate " +
              rate,
          Bin("imuqual") + " run --sim 1 --duration 10 --lot L --db " + db + " --rate " + rate,
          Bin("imuqual") + " analyze " + std::string(IMUQUAL_SOURCE_DIR) +
              "/tests/reference/data/white_1e4.txt --rate " + rate}) {
      const auto r = RunCommand(cmd + " 2>&1");
      EXPECT_EQ(r.exit_code, 2) << cmd << ":\n" << r.output;
      EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << cmd << ":\n" << r.output;
      EXPECT_NE(r.output.find("--rate"), std::string::npos) << cmd << ":\n" << r.output;
    }
  }
  // In a station file and in a source, as on the command line.
  const std::string station = dir.path("station.textproto");
  {
    std::ofstream(station) << "station_id: \"s\"\nlot: \"L\"\nplan: \"builtin:vg700ca\"\n"
                           << "duration_s: 10\narchive: \"rate.db\"\nrate_hz: 0\n"
                           << "slot { name: \"A1\" unit_serial: \"U1\" source: \"sim:vg700\" }\n";
  }
  auto r = RunCommand(Bin("imuqual") + " run --station " + station + " 2>&1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find(station + ":6: rate_hz"), std::string::npos) << r.output;
  r = RunCommand(Bin("imuqual-acquire") + " --lcm-url " + bus +
                 " --lot L --duration 10 --unit U1=sim:vg700,rate=0 2>&1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find("rate must be > 0"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(db));  // refused before anything was created
}

// A plan that requires an operator refuses a soak without one, on every
// command that starts one, before anything is created.
TEST(BadInputTest, APlanThatRequiresAnOperatorRefusesASoakWithoutOne) {
  testing::TempDir dir("no_operator");
  const std::string db = dir.path("op.db");
  const std::string plan = dir.path("signed.textproto");
  std::ofstream(plan) << "name: \"signed\" axes { name: \"x\" kind: GYRO } nominal_rate_hz: 100 "
                         "min_duration_s: 10 require_operator: true\n";
  const std::string bus = "'udpm://239.255.76.67:7996?ttl=0'";
  for (const std::string& cmd :
       {Bin("imuqual") + " run --unit U1=sim:vg700 --duration 10 --lot L --db " + db + " --plan " +
            plan,
        Bin("imuqual-acquire") + " --lcm-url " + bus +
            " --lot L --unit U1=sim:vg700 --duration 10 --plan " + plan}) {
    const auto r = RunCommand(cmd + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << cmd << ":\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_NE(r.output.find("plan signed requires an operator: give --operator NAME"),
              std::string::npos)
        << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(db));
}

// A plan or station file that is not there is bad input (exit 2), not the
// archive that could not be written (exit 4: README, exit codes).
TEST(BadInputTest, AMissingPlanOrStationFileExitsTwoNotFour) {
  testing::TempDir dir("missing_files");
  const std::string db = dir.path("m.db");
  const std::string plan = dir.path("no-such-plan.textproto");
  const std::string station = dir.path("no-such-station.textproto");
  for (const auto& [cmd, named] :
       {std::pair{Bin("imuqual") + " run --unit U1=sim:vg700 --duration 10 --lot L --db " + db +
                      " --plan " + plan,
                  plan},
        std::pair{Bin("imuqual") + " run --station " + station, station}}) {
    const auto r = RunCommand(cmd + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << cmd << ":\n" << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_NE(r.output.find("imuqual: error: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(named), std::string::npos) << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(db));
}

TEST(BadInputTest, ACsvWithoutSamplesIsRefusedNamingTheFile) {
  testing::TempDir dir("bad_csv_empty");
  const std::string empty = dir.path("empty.csv"), header = dir.path("header.csv");
  { std::ofstream(empty) << ""; }
  { std::ofstream(header) << "gx,gy,gz\n"; }
  for (const std::string& file : {empty, header}) {
    const std::string unit = " --unit U1=csv:" + file + ",rate=100,axes=gx/gy/gz";
    // imuqual-acquire refuses it with one line naming the file ...
    auto r = RunCommand(Bin("imuqual-acquire") +
                        " --lcm-url 'udpm://239.255.76.67:7996?ttl=0' --lot L" + unit + " 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_NE(r.output.find(file + ": "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("no samples"), std::string::npos) << r.output;
    // ... and imuqual run's pre-flight refuses it, naming the slot and the
    // file, before anything starts: no archive, no run of 0 samples.
    const std::string db = dir.path("csv.db");
    r = RunCommand(Bin("imuqual") + " run" + unit + " --lot L --db " + db + " --quiet 2>&1");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("slot 1 (unit U1): " + file + ": "), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(db));
  }
}

// A plan the recordings below pass.
constexpr char kLoosePlan[] =
    R"pb(name: "loose"
         axes { name: "gx" kind: GYRO }
         axes { name: "gy" kind: GYRO }
         axes { name: "gz" kind: GYRO }
         nominal_rate_hz: 100
         min_duration_s: 30
         grid { kind: OCTAVE }
         limits { measurement: "angle_random_walk" axis_kind: GYRO high: 10 unit: "deg/sqrt(h)" }
    )pb";

// A minute of white rate noise at 100 Hz; `bad_row` >= 0 makes that row
// `bad_text` (by default a word in gy's cell).
void WriteRecording(const std::string& path, uint32_t seed, int bad_row,
                    const std::string& bad_text = "0.001,oops,0.002") {
  std::mt19937 gen(seed);
  std::normal_distribution<double> noise(0.0, 0.01);  // deg/s
  std::ofstream out(path);
  out << "gx,gy,gz\n";
  for (int k = 0; k < 6000; ++k) {
    if (k == bad_row) {
      out << bad_text << "\n";
    } else {
      out << noise(gen) << ',' << noise(gen) << ',' << noise(gen) << '\n';
    }
  }
}

TEST(BadInputTest, ASourcesDataErrorExitsThreeAndTheOtherUnitsAreJudgedAndArchived) {
  testing::TempDir dir("bad_csv_cell");
  const std::string plan = dir.path("loose.textproto");
  { std::ofstream(plan) << kLoosePlan; }
  WriteRecording(dir.path("g1.csv"), 1, -1);
  WriteRecording(dir.path("b1.csv"), 2, 3000, "0.001,0.002");  // line 3002 of the file
  WriteRecording(dir.path("g2.csv"), 3, -1);
  const std::string db = dir.path("cell.db");
  // WHEN unit B1's recording has a row of two fields for three columns half-way
  const auto r = RunCommand(Bin("imuqual") + " run --unit G1=csv:" + dir.path("g1.csv") +
                            ",rate=100 --unit B1=csv:" + dir.path("b1.csv") +
                            ",rate=100 --unit G2=csv:" + dir.path("g2.csv") + ",rate=100 --plan " +
                            plan + " --lot CELL --db " + db + " --quiet 2>&1");
  // THEN imuqual run exits with the source-failure code and says which unit and why, in one line
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_EQ(ErrorLines(r.output), 1) << r.output;
  EXPECT_NE(
      r.output.find("error: 1 of 3 units' sources failed, their runs archived as ERROR: B1 (" +
                    dir.path("b1.csv") + ":3002: 2 fields, column 'gz' is field 3)"),
      std::string::npos)
      << r.output;
  // AND B1 is archived as aborted with the verdict ERROR (its source failed:
  // nothing is said of the unit) and that reason, while G1 and G2 ran to the
  // end and were judged and archived.
  auto archive = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok()) << archive.status().message();
  store::RunFilter lot;
  lot.lot = "CELL";
  auto runs = store::QueryRuns(**archive, lot);
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 3u) << r.output;
  for (const store::RunRow& run : *runs) {
    if (run.unit == "B1") {
      EXPECT_EQ(run.state, "aborted");
      EXPECT_EQ(run.verdict, "ERROR");
      EXPECT_NE(run.reasons.find("b1.csv:3002: 2 fields, column 'gz' is field 3"),
                std::string::npos)
          << run.reasons;
    } else {
      EXPECT_EQ(run.state, "complete") << run.unit;
      EXPECT_EQ(run.verdict, "PASS") << run.unit << ": " << run.reasons;
    }
  }
  store::AxisRowFilter rows_of_lot;
  rows_of_lot.lot = "CELL";
  auto rows = store::QueryAxisRows(**archive, rows_of_lot);
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), 9u);
  for (const store::AxisRow& row : *rows) {
    if (row.unit != "B1") {
      EXPECT_EQ(row.samples, 6000) << row.unit << " " << row.axis;
    }
  }
}

// One rule for bad samples: a word in an axis's cell is an invalid sample of
// that axis, as "nan" or an empty cell is, counted on that axis and judged
// by the plan's invalid_fraction; it never ends the unit's run.
TEST(BadInputTest, ATextCellIsAnInvalidSampleOfItsAxisNotAnError) {
  testing::TempDir dir("text_cell");
  const std::string plan = dir.path("loose.textproto");
  { std::ofstream(plan) << kLoosePlan; }
  // GIVEN unit T1's recording with a word in gy's cell of row 3000 (line
  // 3002) and "nan" and an empty cell in later rows of gy and gz
  WriteRecording(dir.path("t1.csv"), 2, 3000);
  {
    std::ofstream out(dir.path("t1.csv"), std::ios::app);
    out << "0.001,nan,0.002\n0.001,0.003,\n";
  }
  const std::string db = dir.path("cell.db");
  // WHEN it is soaked
  const auto r = RunCommand(Bin("imuqual") + " run --unit T1=csv:" + dir.path("t1.csv") +
                            ",rate=100 --plan " + plan + " --lot TEXT --db " + db + " 2>&1");
  // THEN the run completes and is judged, its table shows the invalid
  // samples, and the process log says once where the word was
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("invalid samples"), std::string::npos) << r.output;
  auto log = ReadFileToString(db + ".log");
  ASSERT_TRUE(log.ok()) << log.status().message();
  EXPECT_NE(log->find(dir.path("t1.csv") + ":3002: 'oops' is not a number (column 'gy'): "
                                           "read as an invalid sample of that axis"),
            std::string::npos)
      << *log;
  // AND gy counts two invalid samples (the word and "nan"), gz one, gx none
  const auto lot = RunCommand(Bin("imuqual") + " lot TEXT --db " + db + " --format csv");
  ASSERT_EQ(lot.exit_code, 0) << lot.output;
  const std::map<std::string, std::string> invalid_of =
      LotColumnByAxis(lot.output, "invalid_samples");
  EXPECT_EQ(LotColumnByAxis(lot.output, "verdict"),
            (std::map<std::string, std::string>{{"gx", "PASS"}, {"gy", "PASS"}, {"gz", "PASS"}}))
      << lot.output;
  EXPECT_EQ(invalid_of, (std::map<std::string, std::string>{{"gx", "0"}, {"gy", "2"}, {"gz", "1"}}))
      << lot.output;
}

// Pre-flight: every slot's source is opened before anything starts, and
// every problem is listed at once at its slot's line of the station file;
// --skip-failed-slots runs the others and names the ones left out.
TEST(BadInputTest, PreflightListsEveryBadSlotAtOnceAndCanSkipThem) {
  testing::TempDir dir("preflight");
  // A plan for the simulated VG700 units' axes, 30 s of soak.
  std::ofstream(dir.path("xyz.textproto"))
      << "name: \"xyz\" axes { name: \"x\" kind: GYRO } axes { name: \"y\" kind: GYRO } "
         "axes { name: \"z\" kind: GYRO } nominal_rate_hz: 100 min_duration_s: 30\n";
  {
    std::ofstream csv(dir.path("r1.csv"));
    csv << "x,y,z\n";
    for (int k = 0; k < 6000; ++k) csv << 0.001 * (k % 7) << ",0.002,-0.001\n";
  }
  const std::string station = dir.path("station.textproto");
  auto write = [&](const std::string& sim_duration) {
    std::ofstream(station)
        << "station_id: \"s\"\nlot: \"PRE\"\nplan: \"xyz.textproto\"\nduration_s: 60\n"
        << "archive: \"pre.db\"\n"
        << "slot { name: \"A1\" unit_serial: \"U1\" source: \"csv:r1.csv,rate=100\" }\n"
        << "slot { name: \"A2\" unit_serial: \"U2\" source: "
           "\"serial:/dev/imuqual-no-such-port-2,protocol=xsens\" }\n"
        << "slot { name: \"A3\" unit_serial: \"U3\"\n"
        << "       source: \"serial:/dev/imuqual-no-such-port,protocol=text,columns=x/y/z\" }\n"
        << "slot { name: \"A4\" unit_serial: \"U4\" source: \"sim:vg700,duration=" << sim_duration
        << "\" }\n"
        << "slot { name: \"A5\" unit_serial: \"U5\" source: \"sim:tactical\" }\n";
  };
  // GIVEN a station file with two serial ports that are not there (lines 7
  // and 8), a simulated unit soaked 5 s under a plan
  // that needs 30 s (line 10) and one whose axes are not the plan's (line 11)
  write("5");
  auto r = RunCommand(Bin("imuqual") + " run --station " + station + " --quiet 2>&1");
  // THEN nothing starts, exit 2, and the four problems are named at once
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("pre-flight: 4 problems, nothing started"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(station + ":7: slot A2 (unit U2): "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("/dev/imuqual-no-such-port-2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(station + ":8: slot A3 (unit U3): "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("/dev/imuqual-no-such-port"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(station + ":10: slot A4 (unit U4): a soak of 5 s is shorter than"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(station + ":11: slot A5 (unit U5): source axes gx(gyro)"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("slot A1"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.path("pre.db")));
  // A short soak is the station's problem: --skip-failed-slots does not skip it.
  r = RunCommand(Bin("imuqual") + " run --station " + station +
                 " --skip-failed-slots --quiet 2>&1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir.path("pre.db")));
  // WHEN the soak is long enough and the operator skips the failed slots
  write("60");
  r = RunCommand(Bin("imuqual") + " run --station " + station +
                 " --skip-failed-slots --quiet 2>&1");
  // THEN A1 and A4 run and are archived; A2, A3 and A5 are named as not run
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const std::string slot :
       {":7: slot A2 (unit U2)", ":8: slot A3 (unit U3)", ":11: slot A5 (unit U5)"}) {
    EXPECT_NE(r.output.find("not run (--skip-failed-slots): " + station + slot), std::string::npos)
        << r.output;
  }
  auto archive = store::Archive::Open(dir.path("pre.db"), store::Archive::Mode::kRead);
  ASSERT_TRUE(archive.ok()) << archive.status().message();
  store::RunFilter lot;
  lot.lot = "PRE";
  auto runs = store::QueryRuns(**archive, lot);
  ASSERT_TRUE(runs.ok());
  std::set<std::string> units;
  for (const store::RunRow& run : *runs) units.insert(run.unit);
  EXPECT_EQ(units, (std::set<std::string>{"U1", "U4"})) << r.output;
  // Unnamed slots keep their numbers when a slot before them is skipped.
  const std::string csv = ",rate=100 ";
  r = RunCommand(Bin("imuqual") + " run --unit G1=csv:" + dir.path("r1.csv") + csv +
                 "--unit B2=csv:" + dir.path("missing.csv") + csv + "--unit G3=csv:" +
                 dir.path("r1.csv") + csv + "--plan " + dir.path("xyz.textproto") +
                 " --lot NUM --db " + dir.path("num.db") + " --skip-failed-slots --quiet 2>&1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("not run (--skip-failed-slots): slot 2 (unit B2)"), std::string::npos)
      << r.output;
  const auto listed = RunCommand(Bin("imuqual") + " runs --lot NUM --format csv --db " +
                                 dir.path("num.db"));
  EXPECT_NE(listed.output.find(",G1,NUM,station-1,1,"), std::string::npos) << listed.output;
  EXPECT_NE(listed.output.find(",G3,NUM,station-1,3,"), std::string::npos) << listed.output;
}

TEST(BadInputTest, AReadOnlyDirectoryIsAClearError) {
  if (std::getenv("IMUQUAL_NETNS") == nullptr) {
    GTEST_SKIP() << "needs the private mount namespace of tests/netns_run";
  }
  testing::TempDir dir("bad_readonly");
  const std::string ro = dir.path("ro");
  std::filesystem::create_directories(ro);
  // Read-only even for root: a read-only mount.
  ASSERT_EQ(::mount("tmpfs", ro.c_str(), "tmpfs", MS_RDONLY, "size=64k"), 0)
      << std::strerror(errno);
  struct Unmount {
    std::string dir;
    ~Unmount() { ::umount2(dir.c_str(), MNT_DETACH); }
  } unmount{ro};
  const auto r =
      RunCommand(Bin("imuqual-store") + " --lcm-url 'udpm://239.255.76.67:7998?ttl=0' --db " + ro +
                 "/a.db 2>&1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_NE(r.output.find("cannot write the archive " + ro + "/a.db"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("Read-only file system"), std::string::npos) << r.output;
}

TEST(BadInputTest, AFullDiskStopsAcknowledgementsButLosesNothingAccepted) {
  if (std::getenv("IMUQUAL_NETNS") == nullptr) {
    GTEST_SKIP() << "needs the private mount namespace of tests/netns_run";
  }
  StationHarness h("bad_disk");
  const std::string small = h.path("small");
  std::filesystem::create_directories(small);
  ASSERT_EQ(::mount("tmpfs", small.c_str(), "tmpfs", 0, "size=400k"), 0) << std::strerror(errno);
  struct Unmount {
    std::string dir;
    ~Unmount() { ::umount2(dir.c_str(), MNT_DETACH); }
  } unmount{small};
  const std::string db = small + "/full.db";
  Subprocess store =
      h.Start("imuqual-store", {"--db", db, "--give-up", "5", "--stale-after", "60"});
  ASSERT_TRUE(h.WaitReported("store", store.pid(), 20));
  FakeAcquire acq(h, "FULL-1", "FULL-U01");
  acq.Announce(imuqual::run_t::STATE_RUNNING, -1, 0);
  // Far more than 400 KB of samples (3 axes x 50 x 4 bytes x 2000 = 1.2 MB).
  for (int64_t seq = 0; seq < 2000; ++seq) {
    acq.Send(acq.Batch(seq, seq * kSamples));
    if (seq % 50 == 0) h.Pump(5);
  }
  // The store reports the failure and keeps running.
  EXPECT_GE(h.WaitCounter("store", "commit_failures", 1, 30), 1) << h.Logs();
  h.Pump(1500);
  EXPECT_FALSE(store.Poll().has_value()) << h.Logs();
  EXPECT_NE(h.Logs().find("disk is full"), std::string::npos) << h.Logs();
  // Stopped with the disk still full: a clear error, what it could not write
  // named; everything acknowledged is in the file, which is intact.
  EXPECT_EQ(store.Stop(15), store::kStoreExitUnwritable);
  EXPECT_NE(h.Logs().find("batches received are not archived and were not acknowledged"),
            std::string::npos)
      << h.Logs();
  auto a = store::Archive::Open(db, store::Archive::Mode::kRead);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  auto check = (*a)->db().Prepare("PRAGMA integrity_check");
  ASSERT_TRUE(*check->Step());
  EXPECT_EQ(check->Text(0), "ok");
  auto next = (*a)->NextMissingSeq(**(*a)->FindRunKey("FULL-1"));
  ASSERT_TRUE(next.ok());
  EXPECT_GT(*next, 0);
  EXPECT_LE(h.StoreAcked("FULL-1"), *next);  // never acknowledged what is not there
  EXPECT_LT(*next, 2000);                    // the disk really filled up
}

}  // namespace
}  // namespace imuqual
