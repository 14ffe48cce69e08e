// The bag source on bags this test writes with rosbag_storage (C++17, as the
// source): channels in deg/s and m/s^2, header.seq as the counter (a jump is
// a gap) or the message index when seq is constant, stamps as arrival times,
// errors that name the file and the topic; and a whole station soaking a bag.
#include "acquire/rosbag_source.h"

#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <std_msgs/String.h>

#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "acquire/source_spec.h"
#include "tests/test_util.h"

namespace imuqual::acquire {
namespace {

using testing::TempDir;

constexpr double kRadPerDeg = 0.017453292519943295;

// `count` messages at 100 Hz on /imu (seq from 40, `skip` messages missing
// after the 10th; seq constant when `constant_seq`), white rate noise of
// `sd_dps` deg/s on the gyros, gravity on az, and one std_msgs/String on /log.
void WriteBag(const std::string& path, int count, int skip, bool constant_seq,
              double sd_dps = 0.01) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  std::mt19937 gen(7);
  std::normal_distribution<double> noise(0.0, sd_dps * kRadPerDeg);
  for (int i = 0, k = 0; i < count; ++i, ++k) {
    if (i == 10) k += skip;
    sensor_msgs::Imu m;
    m.header.seq = constant_seq ? 0 : static_cast<uint32_t>(40 + k);
    m.header.stamp = ros::Time(1000.0 + 0.01 * k);
    m.angular_velocity.x = i == 0 ? 1.0 : noise(gen);  // 1 rad/s first
    m.angular_velocity.y = noise(gen);
    m.angular_velocity.z = noise(gen);
    m.linear_acceleration.z = 9.80665;
    bag.write("/imu", m.header.stamp, m);
  }
  std_msgs::String s;
  s.data = "hello";
  bag.write("/log", ros::Time(1000.0), s);
}

Result<std::unique_ptr<SampleSource>> Make(const std::string& text) {
  auto spec = ParseSourceSpec(text);
  if (!spec.ok()) return spec.status();
  return MakeSource(*spec, SourceDefaults{});
}

TEST(RosbagSourceTest, ChannelsCountersAndStamps) {
  TempDir dir("rosbag_source");
  const std::string bag = dir.path("imu.bag");
  WriteBag(bag, 30, 5, false);
  auto source = Make("bag:" + bag + ",rate=100");
  ASSERT_TRUE(source.ok()) << source.status().message();
  ASSERT_EQ((*source)->info().axes.size(), 6u);
  EXPECT_EQ((*source)->info().axes[3].name(), "ax");
  EXPECT_EQ((*source)->info().axes[3].kind(), pb::ACCEL);
  SampleBlock block;
  auto n = (*source)->Read(100, &block);
  ASSERT_TRUE(n.ok()) << n.status().message();
  // THEN the first block ends at the jump of 5 in seq: 10 samples from 0.
  ASSERT_EQ(*n, 10);
  EXPECT_EQ(block.first_sample, 0);
  EXPECT_EQ(block.first_sample_utime, 1000000000);
  EXPECT_FLOAT_EQ(block.samples[0][0], static_cast<float>(1.0 / kRadPerDeg));  // deg/s
  EXPECT_FLOAT_EQ(block.samples[5][0], 9.80665f);                              // m/s^2
  n = (*source)->Read(100, &block);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 20);
  EXPECT_EQ(block.first_sample, 15);  // the 5 missing messages are a gap
  EXPECT_EQ(block.first_sample_utime, 1000150000);
  n = (*source)->Read(100, &block);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 0);  // the end
}

TEST(RosbagSourceTest, ConstantSeqCountsMessagesAndChannelsCanBeChosen) {
  TempDir dir("rosbag_seq");
  const std::string bag = dir.path("imu.bag");
  WriteBag(bag, 30, 5, true);
  auto source = Make("bag:" + bag + ",rate=100,axes=gz/gx");
  ASSERT_TRUE(source.ok()) << source.status().message();
  ASSERT_EQ((*source)->info().axes.size(), 2u);
  EXPECT_EQ((*source)->info().axes[0].name(), "gz");
  SampleBlock block;
  auto n = (*source)->Read(100, &block);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 30);  // no counter to see the missing messages by: one block
  EXPECT_FLOAT_EQ(block.samples[1][0], static_cast<float>(1.0 / kRadPerDeg));
}

TEST(RosbagSourceTest, ErrorsNameTheFileAndTheTopic) {
  TempDir dir("rosbag_errors");
  const std::string bag = dir.path("imu.bag");
  WriteBag(bag, 5, 0, false);
  for (const auto& [text, says] : std::vector<std::pair<std::string, std::string>>{
           {"bag:" + bag + ",rate=100,topic=/imu0",
            "no message on topic /imu0 (the bag has /imu (sensor_msgs/Imu), /log "
            "(std_msgs/String))"},
           {"bag:" + bag + ",rate=100,topic=/log",
            "topic /log carries std_msgs/String, not sensor_msgs/Imu"},
           {"bag:" + bag + ",rate=100,axes=gx/wz",
            "channel 'wz' is not one of gx, gy, gz, ax, ay, az"},
           {"bag:" + bag, "give rate=HZ"},
           {"bag:" + dir.path("none.bag") + ",rate=100", dir.path("none.bag")}}) {
    auto source = Make(text);
    ASSERT_FALSE(source.ok()) << text;
    EXPECT_NE(source.status().message().find(says), std::string::npos)
        << text << ": " << source.status().message();
  }
}

// `imuqual run` soaks a unit recorded in a bag: archived and judged.
TEST(RosbagSourceTest, AStationSoaksABag) {
  TempDir dir("rosbag_station");
  const std::string bag = dir.path("imu.bag");
  WriteBag(bag, 12000, 0, false);
  std::ofstream(dir.path("plan.textproto"))
      << "name: \"bag\" axes { name: \"gx\" kind: GYRO } axes { name: \"gy\" kind: GYRO } "
         "axes { name: \"gz\" kind: GYRO } nominal_rate_hz: 100 min_duration_s: 60 "
         "limits { measurement: \"angle_random_walk\" axis_kind: GYRO high: 10 "
         "unit: \"deg/sqrt(h)\" }\n";
  const auto run = testing::RunCommand(
      std::string(IMUQUAL_BIN_DIR) + "/imuqual run --unit B1=bag:" + bag + " --plan " +
      dir.path("plan.textproto") + " --lot BAG --db " + dir.path("bag.db") + " --quiet 2>&1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // White noise of 0.01 deg/s at 100 Hz: ARW 0.01 x sqrt(0.01 s) x 60 = 0.06
  // deg/sqrt(h), under the limit of 10: the run's verdict, as archived.
  const auto runs =
      testing::RunCommand(std::string(IMUQUAL_BIN_DIR) +
                          "/imuqual runs --lot BAG --format csv --db " + dir.path("bag.db"));
  ASSERT_EQ(runs.exit_code, 0) << runs.output;
  EXPECT_NE(runs.output.find(",B1,BAG,"), std::string::npos) << runs.output;
  EXPECT_NE(runs.output.find(",complete,PASS,"), std::string::npos) << runs.output;
  const auto csv = testing::RunCommand(std::string(IMUQUAL_BIN_DIR) +
                                       "/imuqual export --lot BAG --format measurements --db " +
                                       dir.path("bag.db"));
  ASSERT_EQ(csv.exit_code, 0);
  EXPECT_NE(csv.output.find(",angle_random_walk,"), std::string::npos) << csv.output.substr(0, 400);
}

}  // namespace
}  // namespace imuqual::acquire
