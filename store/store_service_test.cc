// The store's write-failure path: a batch that arrived but could not be
// written (full disk, injected through StoreOptions::before_commit) is held,
// never acknowledged and never recorded as a gap, and is written once the
// archive writes again; an archive that never writes again ends Run() with
// an error and acknowledges nothing it does not hold. The store runs in a
// thread on a bus of its own (fresh port, ttl=0); the test plays acquire.
#include "store/store_service.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <map>
#include <random>
#include <thread>

#include "common/batch_integrity.h"
#include "common/channels.h"
#include "common/clock.h"
#include "common/lcm_bus.h"
#include "common/shutdown.h"
#include "common/text_util.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/plan.pb.h"
#include "imuqual/rate_batch_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/status_t.hpp"
#include "store/archive.h"
#include "tests/test_util.h"

namespace imuqual::store {
namespace {

constexpr double kRateHz = 100;
constexpr int kSamples = 50;
constexpr double kWaitS = 20;  // bound on every wait for the store

// A store in a thread plus the test's own connection to its bus.
class StoreUnderTest {
 public:
  StoreUnderTest(const std::string& tag, StoreOptions options) : dir_(tag) {
    ResetShutdownForTest();
    BusAddress address;
    address.port = 20000 + static_cast<int>(std::random_device{}() % 40000);
    options.lcm_url = address.ToUrl();
    options.db_path = dir_.path("store.db");
    options.before_commit = [this]() -> Status {
      if (disk_full_) return Status::IoError("database or disk is full");
      return Status::Ok();
    };
    db_ = options.db_path;
    BusSecurity as_acquire;  // the test plays acquire
    as_acquire.role = BusRole::kAcquire;
    auto bus = LcmBus::Open(options.lcm_url, as_acquire);
    EXPECT_TRUE(bus.ok());
    bus_ = std::move(*bus);
    bus_->Subscribe<imuqual::ack_t>(channels::kAck, 1000,
                                    [this](const std::string&, imuqual::ack_t&& a, int64_t) {
                                      if (a.process == "store")
                                        for (int64_t seq : a.next_seq) acked_ = std::max(acked_, seq);
                                    });
    bus_->Subscribe<imuqual::status_t>(channels::kStatus, 1000,
                                       [this](const std::string&, imuqual::status_t&& s, int64_t) {
                                         if (s.process != "store") return;
                                         for (size_t i = 0; i < s.counter_names.size(); ++i) {
                                           counters_[s.counter_names[i]] = s.counter_values[i];
                                         }
                                       });
    auto service = StoreService::Create(options);
    EXPECT_TRUE(service.ok()) << service.status().ToString();
    service_ = std::move(*service);
    thread_ = std::thread([this] {
      run_status_ = service_->Run();
      finished_ = true;
    });
    EXPECT_TRUE(WaitCounter("commits", 0));  // it reports: it listens
  }
  ~StoreUnderTest() {
    if (thread_.joinable()) Stop();
    ResetShutdownForTest();
  }
  Status Stop() {
    RequestShutdown();
    if (thread_.joinable()) thread_.join();
    return run_status_;
  }
  // Waits (bounded) until Run() returns by itself.
  bool WaitFinished() {
    const double until = MonotonicSeconds() + kWaitS;
    while (MonotonicSeconds() < until && !finished_) EXPECT_TRUE(bus_->HandleFor(20).ok());
    return finished_;
  }

  void SetDiskFull(bool full) { disk_full_ = full; }
  void Pump(double seconds) {
    const double until = MonotonicSeconds() + seconds;
    while (MonotonicSeconds() < until) ASSERT_TRUE(bus_->HandleFor(20).ok());
  }
  bool WaitCounter(const std::string& name, int64_t at_least) {
    const double until = MonotonicSeconds() + kWaitS;
    while (MonotonicSeconds() < until) {
      auto it = counters_.find(name);
      if (it != counters_.end() && it->second >= at_least) return true;
      EXPECT_TRUE(bus_->HandleFor(20).ok());
    }
    return false;
  }
  bool WaitAcked(int64_t next_seq) {
    const double until = MonotonicSeconds() + kWaitS;
    while (MonotonicSeconds() < until && acked_ < next_seq) EXPECT_TRUE(bus_->HandleFor(20).ok());
    return acked_ >= next_seq;
  }
  int64_t acked() const { return acked_; }
  int64_t Counter(const std::string& name) const {
    auto it = counters_.find(name);
    return it == counters_.end() ? -1 : it->second;
  }

  void Announce(int64_t last_seq) {
    imuqual::run_t run;
    run.host_utime = NowUtime();
    run.run_id = "FULL-RUN";
    run.unit_serial = "FULL-U1";
    run.lot = "FULL";
    run.station = "test";
    run.source = "fake";
    run.start_utime = 1;
    run.nominal_rate_hz = kRateHz;
    run.num_axes = 1;
    run.axis_names = {"x"};
    run.axis_kinds = {imuqual::rate_batch_t::KIND_GYRO};
    pb::TestPlan plan;
    plan.set_nominal_rate_hz(kRateHz);
    const std::string bytes = plan.SerializeAsString();
    run.plan_size = static_cast<int32_t>(bytes.size());
    run.plan.assign(bytes.begin(), bytes.end());
    run.plan_sha256 = Sha256Hex(bytes);
    run.truth_size = 0;
    run.state = imuqual::run_t::STATE_RUNNING;
    run.last_seq = last_seq;
    run.samples_published = (last_seq + 1) * kSamples;
    run.first_sample = last_seq >= 0 ? 0 : -1;
    run.end_sample = last_seq >= 0 ? run.samples_published : -1;
    run.announcer = "acquire";
    run.retained_first_seq = 0;
    run.revision = 0;
    ASSERT_TRUE(bus_->Publish(channels::kRun, run).ok());
  }
  void Send(int64_t seq) {
    imuqual::rate_batch_t b;
    b.host_utime = NowUtime();
    b.run_id = "FULL-RUN";
    b.unit_serial = "FULL-U1";
    b.seq = seq;
    b.first_sample = seq * kSamples;
    b.nominal_rate_hz = kRateHz;
    b.num_axes = 1;
    b.axis_names = {"x"};
    b.axis_kinds = {imuqual::rate_batch_t::KIND_GYRO};
    b.num_samples = kSamples;
    std::vector<float> v;
    for (int i = 0; i < kSamples; ++i)
      v.push_back(0.01f * static_cast<float>(std::sin(0.37 * (seq * kSamples + i))));
    b.samples = {v};
    b.num_flagged = 0;
    b.has_temperature = 0;
    b.temperature_c = 0;
    std::vector<uint8_t> bytes;  // sealed with its checksum, as acquire sends it
    ASSERT_TRUE(EncodeSealedBatch(&b, &bytes).ok());
    ASSERT_TRUE(bus_->PublishEncoded(channels::Raw("FULL-U1"), bytes).ok());
  }

  // Chunks archived and gap rows of the run, read from the file.
  std::pair<int64_t, int64_t> Archived() const {
    auto a = Archive::Open(db_, Archive::Mode::kRead);
    EXPECT_TRUE(a.ok()) << a.status().ToString();
    if (!a.ok()) return {-1, -1};
    auto key = (*a)->FindRunKey("FULL-RUN");
    EXPECT_TRUE(key.ok() && key->has_value());
    auto seqs = (*a)->ArchivedSeqsFrom(**key, 0);
    auto gaps = (*a)->LoadGaps(**key);
    EXPECT_TRUE(seqs.ok() && gaps.ok());
    return {static_cast<int64_t>(seqs->size()), static_cast<int64_t>(gaps->size())};
  }

 private:
  testing::TempDir dir_;
  std::string db_;
  std::unique_ptr<LcmBus> bus_;
  std::unique_ptr<StoreService> service_;
  std::thread thread_;
  Status run_status_;
  std::atomic<bool> disk_full_{false};
  std::atomic<bool> finished_{false};
  int64_t acked_ = -1;
  std::map<std::string, int64_t> counters_;
};

TEST(StoreServiceTest, AFailedWriteIsHeldUnacknowledgedNeverAGapAndWrittenLater) {
  StoreOptions options;
  options.hole_give_up_s = 0.5;  // far shorter than the full disk lasts
  StoreUnderTest store("store_full_then_freed", options);
  // GIVEN 10 batches archived and acknowledged
  store.Announce(-1);
  ASSERT_TRUE(store.WaitCounter("runs_active", 1));
  for (int64_t seq = 0; seq < 10; ++seq) store.Send(seq);
  store.Announce(9);
  ASSERT_TRUE(store.WaitAcked(10)) << store.acked();
  // WHEN the disk is full while 20 more arrive and are announced, for
  // several times the hole give-up time
  store.SetDiskFull(true);
  for (int64_t seq = 10; seq < 30; ++seq) store.Send(seq);
  for (int i = 0; i < 6; ++i) {
    store.Announce(29);
    store.Pump(0.5);
  }
  // THEN they are held, none is acknowledged, none given up as a gap
  ASSERT_TRUE(store.WaitCounter("batches_unwritten", 20));
  EXPECT_GE(store.Counter("commit_failures"), 2);  // retried with back-off
  EXPECT_EQ(store.acked(), 10);
  EXPECT_EQ(store.Counter("batches_given_up"), 0);
  // WHEN the disk has room again, without any batch being resent
  store.SetDiskFull(false);
  // THEN every batch is written, then acknowledged; no gap anywhere
  ASSERT_TRUE(store.WaitAcked(30)) << store.acked();
  EXPECT_EQ(store.Counter("batches_given_up"), 0);
  EXPECT_EQ(store.Counter("unwritten_dropped"), 0);
  ASSERT_TRUE(store.Stop().ok());
  EXPECT_EQ(store.Archived(), (std::pair<int64_t, int64_t>{30, 0}));
}

TEST(StoreServiceTest, ADiskThatStaysFullEndsWithAnErrorAndNothingUnarchivedAcknowledged) {
  StoreOptions options;
  options.hole_give_up_s = 0.5;
  options.write_give_up_s = 2;
  StoreUnderTest store("store_full_forever", options);
  store.Announce(-1);
  ASSERT_TRUE(store.WaitCounter("runs_active", 1));
  for (int64_t seq = 0; seq < 5; ++seq) store.Send(seq);
  store.Announce(4);
  ASSERT_TRUE(store.WaitAcked(5));
  // WHEN the disk fills for good
  store.SetDiskFull(true);
  for (int64_t seq = 5; seq < 15; ++seq) store.Send(seq);
  store.Announce(14);
  ASSERT_TRUE(store.WaitCounter("batches_unwritten", 10));
  // THEN Run() ends by itself with an error that says what is not archived
  ASSERT_TRUE(store.WaitFinished());
  const Status st = store.Stop();
  EXPECT_EQ(st.code(), Status::Code::kIoError) << st.ToString();
  EXPECT_NE(st.message().find("database or disk is full"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("10 batches received are not archived"), std::string::npos)
      << st.message();
  // AND only what is archived was acknowledged
  EXPECT_EQ(store.acked(), 5);
  EXPECT_EQ(store.Archived(), (std::pair<int64_t, int64_t>{5, 0}));
}

}  // namespace
}  // namespace imuqual::store
