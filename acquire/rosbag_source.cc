// Compiled as C++17: ROS 1 message headers use std::allocator<void>::rebind,
// which C++20 removed.
#include "acquire/rosbag_source.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

namespace imuqual::acquire {
namespace {

constexpr double kDegPerRad = 57.295779513082320876798;  // 180 / pi (no std::numbers in C++17)

double Channel(const sensor_msgs::Imu& m, int channel) {
  switch (channel) {
    case 0:
      return m.angular_velocity.x * kDegPerRad;
    case 1:
      return m.angular_velocity.y * kDegPerRad;
    case 2:
      return m.angular_velocity.z * kDegPerRad;
    case 3:
      return m.linear_acceleration.x;
    case 4:
      return m.linear_acceleration.y;
    default:
      return m.linear_acceleration.z;
  }
}

}  // namespace

struct RosbagSource::Impl {
  RosbagSourceOptions options;
  rosbag::Bag bag;
  std::unique_ptr<rosbag::View> view;
  rosbag::View::iterator next;
  std::vector<int> channels;  // indices into ChannelNames()
  bool by_seq = true;         // counter from header.seq, else the index
  int64_t index = 0;          // messages read
  std::optional<uint32_t> first_seq;
  int64_t last_counter = -1;
  std::optional<sensor_msgs::Imu> pending;  // read, not yet delivered
  int64_t pending_counter = 0;
  bool done = false;

  // The next message of the topic and its counter; nullopt at the end.
  Result<bool> Advance() {
    while (next != view->end()) {
      // The iterator's message is valid until it moves on: decoded first.
      boost::shared_ptr<sensor_msgs::Imu> m;
      try {
        m = next->instantiate<sensor_msgs::Imu>();
      } catch (const std::exception& e) {
        return Status::InvalidArgument(options.path + ": topic " + options.topic + " message " +
                                       std::to_string(index) + " does not decode (" + e.what() +
                                       ")");
      }
      if (!m) {
        return Status::InvalidArgument(options.path + ": topic " + options.topic + " carries " +
                                       next->getDataType() + ", not sensor_msgs/Imu");
      }
      ++next;
      int64_t counter = index;
      if (by_seq) {
        if (!first_seq) first_seq = m->header.seq;
        counter = static_cast<int64_t>(m->header.seq) - static_cast<int64_t>(*first_seq);
        if (counter <= last_counter) {
          return Status::InvalidArgument(options.path + ": topic " + options.topic + " message " +
                                         std::to_string(index) + ": header.seq " +
                                         std::to_string(m->header.seq) +
                                         " does not increase (a repeated or earlier message)");
        }
      }
      ++index;
      last_counter = counter;
      pending = *m;
      pending_counter = counter;
      return true;
    }
    return false;
  }
};

const std::vector<std::string>& RosbagSource::ChannelNames() {
  static const std::vector<std::string> kNames = {"gx", "gy", "gz", "ax", "ay", "az"};
  return kNames;
}

RosbagSource::RosbagSource(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RosbagSource::~RosbagSource() = default;

Result<std::unique_ptr<RosbagSource>> RosbagSource::Open(const RosbagSourceOptions& options) {
  const std::string where = "bag " + options.path;
  if (!(options.rate_hz > 0) || !std::isfinite(options.rate_hz)) {
    return Status::InvalidArgument(where + ": rate must be > 0 Hz");
  }
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  const std::vector<std::string>& names = ChannelNames();
  std::vector<std::string> wanted = options.channels.empty() ? names : options.channels;
  std::set<std::string> seen;
  for (const std::string& c : wanted) {
    const auto it = std::find(names.begin(), names.end(), c);
    if (it == names.end() || !seen.insert(c).second) {
      return Status::InvalidArgument(where + ": channel '" + c +
                                     "' is not one of gx, gy, gz, ax, ay, az (each once)");
    }
    impl->channels.push_back(static_cast<int>(it - names.begin()));
  }
  try {
    impl->bag.open(options.path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    return Status::IoError(where + ": " + e.what());
  }
  impl->view = std::make_unique<rosbag::View>(
      impl->bag, rosbag::TopicQuery(std::vector<std::string>{options.topic}));
  if (impl->view->size() == 0) {
    rosbag::View all(impl->bag);
    std::string topics;
    for (const rosbag::ConnectionInfo* c : all.getConnections()) {
      topics += (topics.empty() ? "" : ", ") + c->topic + " (" + c->datatype + ")";
    }
    return Status::InvalidArgument(where + ": no message on topic " + options.topic +
                                   " (the bag has " + (topics.empty() ? "no topic" : topics) + ")");
  }
  impl->next = impl->view->begin();
  // A recorder that leaves seq constant: count messages instead.
  {
    rosbag::View::iterator probe = impl->view->begin();
    boost::shared_ptr<sensor_msgs::Imu> first, second;
    try {
      first = probe->instantiate<sensor_msgs::Imu>();
      ++probe;
      if (first && probe != impl->view->end()) second = probe->instantiate<sensor_msgs::Imu>();
    } catch (const std::exception&) {
      // Advance() below names the message that does not decode.
    }
    if (first && second) impl->by_seq = second->header.seq != first->header.seq;
  }
  IMUQUAL_RETURN_IF_ERROR(impl->Advance().status());
  std::unique_ptr<RosbagSource> s(new RosbagSource(std::move(impl)));
  for (int c : s->impl_->channels) {
    pb::Axis a;
    a.set_name(names[c]);
    a.set_kind(c < 3 ? pb::GYRO : pb::ACCEL);
    s->info_.axes.push_back(a);
  }
  s->info_.nominal_rate_hz = options.rate_hz;
  if (options.rate_hz > 0) {
    s->info_.planned_s = static_cast<double>(s->impl_->view->size()) / options.rate_hz;
  }
  s->info_.description = "bag:" + options.path + ",topic=" + options.topic;
  return s;
}

Result<int> RosbagSource::Read(int max_samples, SampleBlock* block) {
  Impl& m = *impl_;
  const size_t axes = m.channels.size();
  block->samples.assign(axes, {});
  block->flags.clear();
  block->temperature_c.reset();
  int n = 0;
  while (n < max_samples && !m.done) {
    if (!m.pending) {
      Result<bool> more = m.Advance();
      if (!more.ok()) return more.status();
      if (!*more) {
        m.done = true;
        break;
      }
    }
    // A block holds consecutive samples: a counter jump starts the next one.
    if (n > 0 && m.pending_counter != block->first_sample + n) break;
    const sensor_msgs::Imu& msg = *m.pending;
    if (n == 0) {
      block->first_sample = m.pending_counter;
      block->first_sample_utime =
          static_cast<int64_t>(msg.header.stamp.sec) * 1000000 + msg.header.stamp.nsec / 1000;
    }
    for (size_t a = 0; a < axes; ++a) {
      block->samples[a].push_back(static_cast<float>(Channel(msg, m.channels[a])));
    }
    m.pending.reset();
    ++n;
  }
  return n;
}

void RosbagSource::Stop() {
  impl_->done = true;
  impl_->pending.reset();
  impl_->view.reset();
  impl_->bag.close();
}

}  // namespace imuqual::acquire
