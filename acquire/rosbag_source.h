// A ROS 1 bag as a unit's source: the sensor_msgs/Imu messages of one topic,
// read with Debian's rosbag_storage library (allan_variance_ros, imu_utils
// and Kalibr users record their IMUs this way).
//
// Each message is one sample of up to six channels: gx, gy, gz from
// angular_velocity (rad/s, published in deg/s) and ax, ay, az from
// linear_acceleration (m/s^2). The device counter is header.seq counted from
// the first message's (a jump is a gap: messages the recorder missed), or the
// message's index in the topic when the recorder left seq constant; a seq
// that does not increase is an error naming the message. header.stamp gives the
// arrival time of each block's first sample (the measured rate and jitter).
// The header of this file names no ROS type: the library's headers need C++17
// and stay in rosbag_source.cc.
#ifndef IMUQUAL_ACQUIRE_ROSBAG_SOURCE_H_
#define IMUQUAL_ACQUIRE_ROSBAG_SOURCE_H_

#include <memory>
#include <string>
#include <vector>

#include "acquire/source.h"
#include "common/status.h"

namespace imuqual::acquire {

struct RosbagSourceOptions {
  std::string path;
  std::string topic = "/imu";
  double rate_hz = 0;  // the unit's nominal rate, > 0
  // The channels published, in order, from gx gy gz ax ay az (empty: all six).
  std::vector<std::string> channels;
};

class RosbagSource : public SampleSource {
 public:
  // Opens the bag and finds the topic's first message; errors name the file
  // and the topic: a topic with no message is refused listing the bag's
  // topics, one of another type naming its type.
  static Result<std::unique_ptr<RosbagSource>> Open(const RosbagSourceOptions& options);
  ~RosbagSource() override;
  const SourceInfo& info() const override { return info_; }
  Result<int> Read(int max_samples, SampleBlock* block) override;
  void Stop() override;

  // The channel names a bag source knows, in their default order.
  static const std::vector<std::string>& ChannelNames();

 private:
  struct Impl;
  explicit RosbagSource(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  SourceInfo info_;
};

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_ROSBAG_SOURCE_H_
