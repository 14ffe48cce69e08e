#include "tests/station_harness.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <random>

#include "common/channels.h"
#include "common/clock.h"
#include "common/text_util.h"
#include "imuqual/ack_t.hpp"
#include "imuqual/run_t.hpp"
#include "imuqual/status_t.hpp"

namespace imuqual::testing {

StationHarness::StationHarness(const std::string& tag, HarnessKeys keys,
                               const StationHarness* keys_of)
    : dir_(tag), keys_(keys_of ? keys_of->keys_ : keys) {
  std::random_device rd;
  BusAddress address;
  address.port = 20000 + static_cast<int>((rd() ^ static_cast<unsigned>(::getpid())) % 40000);
  url_ = address.ToUrl();
  db_ = dir_.path("station.db");
  if (keys_of != nullptr) {
    for (BusRole role : {BusRole::kAcquire, BusRole::kAnalyze, BusRole::kStore}) {
      if (keys_of->sign_key(role).empty()) continue;
      std::filesystem::copy_file(keys_of->sign_key(role), sign_key(role));
      std::filesystem::copy_file(keys_of->sign_key(role) + ".pub", sign_key(role) + ".pub");
    }
    if (!keys_of->key_file().empty()) std::filesystem::copy_file(keys_of->key_file(), key_file());
    if (!keys_of->trust_file().empty())
      std::filesystem::copy_file(keys_of->trust_file(), trust_file());
  } else if (keys_ != HarnessKeys::kNone) {
    EXPECT_TRUE(WriteStationKeyFile(key_file(), *GenerateStationKey()).ok());
  }
  if (keys_of == nullptr && keys_ == HarnessKeys::kStationAndRoles) {
    std::string trust;
    for (BusRole role : {BusRole::kAcquire, BusRole::kAnalyze, BusRole::kStore}) {
      auto key = GenerateSigningKey(RoleName(role));
      EXPECT_TRUE(WriteSigningKeyFiles(sign_key(role), *key).ok());
      trust += key->Public().ToText() + "\n";
    }
    EXPECT_TRUE(WriteStringToFile(trust_file(), trust).ok());
  }
  auto bus = LcmBus::Open(url_, Security(BusRole::kTool));
  EXPECT_TRUE(bus.ok()) << bus.status().ToString();
  bus_ = std::move(*bus);
  bus_->Subscribe<imuqual::status_t>(channels::kStatus, 1000,
                                     [this](const std::string&, imuqual::status_t&& s, int64_t) {
                                       instance_[s.process] = s.instance;
                                       auto& c = counters_[s.process];
                                       auto& mine = instance_counters_[s.instance];
                                       for (int i = 0; i < s.num_counters; ++i) {
                                         c[s.counter_names[i]] = s.counter_values[i];
                                         mine[s.counter_names[i]] = s.counter_values[i];
                                       }
                                     });
  bus_->SubscribeWithOrigin<imuqual::ack_t>(
      channels::kAck, 50000, nullptr,
      [this](const std::string&, imuqual::ack_t&& a, const MessageOrigin& from) {
                                    if (a.process != "store" || from.role != BusRole::kStore) return;
                                    for (int i = 0; i < a.num_runs; ++i) {
                                      if (a.run_done[i]) runs_done_.insert(a.run_ids[i]);
                                      int64_t& acked = store_acked_[a.run_ids[i]];
                                      acked = std::max(acked, a.next_seq[i]);
                                    }
                                  });
  bus_->Subscribe<imuqual::run_t>(channels::kRun, 1000,
                                  [this](const std::string&, imuqual::run_t&& r, int64_t) {
                                    runs_seen_.insert(r.run_id);
                                  });
}

std::string StationHarness::key_file() const {
  return keys_ == HarnessKeys::kNone ? "" : dir_.path("station.key");
}

std::string StationHarness::trust_file() const {
  return keys_ == HarnessKeys::kStationAndRoles ? dir_.path("station.trust") : "";
}

std::string StationHarness::sign_key(BusRole role) const {
  if (keys_ != HarnessKeys::kStationAndRoles || !IsSigningRole(RoleName(role))) return "";
  return dir_.path(std::string(RoleName(role)) + ".key");
}

std::vector<std::string> StationHarness::SecurityArgs(BusRole role) const {
  std::vector<std::string> args;
  if (!key_file().empty()) args.insert(args.end(), {"--key-file", key_file()});
  if (!trust_file().empty()) args.insert(args.end(), {"--trust", trust_file()});
  if (!sign_key(role).empty()) args.insert(args.end(), {"--sign-key", sign_key(role)});
  return args;
}

BusSecurity StationHarness::Security(BusRole role) const {
  BusSecurityFiles files;
  files.key_file = key_file();
  files.trust_file = trust_file();
  files.sign_key = sign_key(role);
  auto security = files.Load(role);
  EXPECT_TRUE(security.ok()) << security.status().message();
  return security.ok() ? *security : BusSecurity{};
}

LcmBus& StationHarness::BusAs(BusRole role) {
  std::unique_ptr<LcmBus>& bus = role_buses_[role];
  if (!bus) {
    auto opened = LcmBus::Open(url_, Security(role));
    EXPECT_TRUE(opened.ok()) << opened.status().ToString();
    bus = std::move(*opened);
  }
  return *bus;
}

Subprocess StationHarness::Start(const std::string& program, const std::vector<std::string>& args) {
  std::vector<std::string> argv = {Bin(program), "--lcm-url", url_};
  const BusRole role = program == "imuqual-acquire"   ? BusRole::kAcquire
                       : program == "imuqual-analyze" ? BusRole::kAnalyze
                       : program == "imuqual-store"   ? BusRole::kStore
                                                      : BusRole::kUnknown;
  if (role != BusRole::kUnknown) {
    for (std::string& a : SecurityArgs(role)) argv.push_back(std::move(a));
  }
  argv.insert(argv.end(), args.begin(), args.end());
  auto p = Subprocess::Start(argv, log());
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return std::move(*p);
}

namespace {
// The defaults (FLAG VALUE pairs) that `extra` does not set, then `extra`.
std::vector<std::string> WithDefaults(const std::vector<std::string>& defaults,
                                      const std::vector<std::string>& extra) {
  std::vector<std::string> args;
  for (size_t i = 0; i + 1 < defaults.size(); i += 2) {
    if (std::find(extra.begin(), extra.end(), defaults[i]) == extra.end()) {
      args.insert(args.end(), {defaults[i], defaults[i + 1]});
    }
  }
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}
}  // namespace

Subprocess StationHarness::StartStore(const std::vector<std::string>& extra) {
  const std::vector<std::string> args =
      WithDefaults({"--db", db_, "--give-up", "5", "--stale-after", "2"}, extra);
  Subprocess p = Start("imuqual-store", args);
  EXPECT_TRUE(WaitReported("store", p.pid(), 20)) << Logs();
  return p;
}

Subprocess StationHarness::StartAnalyze(const std::vector<std::string>& extra) {
  const std::vector<std::string> args = WithDefaults({"--give-up", "5", "--stale-after", "4"}, extra);
  Subprocess p = Start("imuqual-analyze", args);
  EXPECT_TRUE(WaitReported("analyze", p.pid(), 20)) << Logs();
  return p;
}

int64_t StationHarness::CounterOf(pid_t pid, const std::string& name) const {
  const std::string suffix = ":" + std::to_string(pid);
  for (const auto& [instance, counters] : instance_counters_) {
    if (instance.size() < suffix.size() ||
        instance.compare(instance.size() - suffix.size(), suffix.size(), suffix) != 0) {
      continue;
    }
    auto it = counters.find(name);
    return it == counters.end() ? -1 : it->second;
  }
  return -1;
}

void StationHarness::Pump(int ms) {
  const double end = MonotonicSeconds() + ms / 1000.0;
  while (MonotonicSeconds() < end) {
    (void)bus_->HandleFor(std::max(1, static_cast<int>((end - MonotonicSeconds()) * 1000)));
  }
}

bool StationHarness::WaitRunsDone(size_t n, double timeout_s) {
  const double end = MonotonicSeconds() + timeout_s;
  while (runs_done_.size() < n && MonotonicSeconds() < end) (void)bus_->HandleFor(50);
  return runs_done_.size() >= n;
}

bool StationHarness::WaitReported(const std::string& process, pid_t pid, double timeout_s) {
  const std::string suffix = ":" + std::to_string(pid);
  const double end = MonotonicSeconds() + timeout_s;
  for (;;) {
    auto it = instance_.find(process);
    if (it != instance_.end() && it->second.size() > suffix.size() &&
        it->second.compare(it->second.size() - suffix.size(), suffix.size(), suffix) == 0) {
      return true;
    }
    if (MonotonicSeconds() > end) return false;
    (void)bus_->HandleFor(50);
  }
}

int64_t StationHarness::Counter(const std::string& process, const std::string& name) const {
  auto p = counters_.find(process);
  if (p == counters_.end()) return -1;
  auto c = p->second.find(name);
  return c == p->second.end() ? -1 : c->second;
}

int64_t StationHarness::WaitCounter(const std::string& process, const std::string& name,
                                    int64_t at_least, double timeout_s) {
  const double end = MonotonicSeconds() + timeout_s;
  while (Counter(process, name) < at_least && MonotonicSeconds() < end) (void)bus_->HandleFor(50);
  return Counter(process, name);
}

std::string StationHarness::Logs() const {
  auto text = ReadFileToString(log());
  return text.ok() ? *text : "(no process log)";
}

}  // namespace imuqual::testing
