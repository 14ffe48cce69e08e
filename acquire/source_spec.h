// Sources named on a command line: KIND:LOCATION[,KEY=VALUE]... with lists in
// values separated by '/'.
//   sim:PROFILE[,index=N][,duration=S][,rate=HZ][,actual_rate=HZ][,seed=N]
//          [,quantize=0|1][,lsb=X[,bits=16]]
//       a simulated unit (lot profile vg700, tactical, fog, mems-lab or mems-real); actual_rate:
//       the simulated device really samples at that rate (rate is nominal);
//       quantize=0: no quantization term (float output); lsb: an ADC of that
//       LSB and width (saturating, flagged)
//   csv:PATH,rate=HZ[,axes=NAME:gyro/NAME:accel...][,counter=COLUMN][,time=COLUMN][,scale=F]
//          [,temperature=COLUMN][,AXIS=COLUMN[:UNIT[:SCALE]]...]
//       a recording; axes default to the plan's axes (by column name), else
//       every column except the counter, as gyros; time: seconds per row;
//       AXIS=...: that axis from another column, in UNIT (gyro deg/s, rad/s,
//       mrad/s, deg/h, rpm; accelerometer m/s^2, g, mg, ug), times SCALE
//       (e.g. an LSB), instead of scale (a column alone keeps scale):
//       gx=wx:rad/s,ax=fx:g,az=acc_z::0.001
//   serial:DEVICE,protocol=text|xsens|crossbow[,rate=HZ][,duration=S][,baud=N]
//          [,parity=none|even|odd][,data_bits=8][,stop_bits=1]
//          [,flow=none|rtscts|xonxoff][,axes=...][,reconnect_timeout=S]
//       text only: columns=NAME/NAME/...(_ skips)[,counter=COL][,counter_bits=N]
//          [,temperature=COL][,scale=F|AXIS:F/...][,delimiter=comma|semicolon|tab|space]
//          [,checksum=none|nmea]
//       crossbow only (crossbow_protocol.h, scaled sensor mode): rate_range=DEG_PER_S
//          [,g_range=G][,checksum=mod256|mod255|either]
//   archive:DB,run=RUN_ID
//       a stored run replayed from its raw chunks
//   bag:PATH[,topic=/imu][,rate=HZ][,axes=gx/gy/gz/ax/ay/az]
//       a ROS 1 bag's sensor_msgs/Imu messages (rosbag_source.h); rate
//       defaults to the plan's, the channels to the plan's axes when each is
//       a channel name, else all six
#ifndef IMUQUAL_ACQUIRE_SOURCE_SPEC_H_
#define IMUQUAL_ACQUIRE_SOURCE_SPEC_H_

#include <map>
#include <memory>
#include <string>

#include "acquire/source.h"
#include "imuqual/plan.pb.h"

namespace imuqual::acquire {

struct SourceSpec {
  std::string kind;      // "sim", "csv", ...
  std::string location;  // profile, path, device
  std::map<std::string, std::string> options;
};

// Parses the text; the error names the spec and the bad part.
Result<SourceSpec> ParseSourceSpec(const std::string& text);

// Every source kind with its keys and one example each, for --help texts
// (imuqual run --unit, imuqual-acquire --source).
inline constexpr char kSourceSpecHelp[] =
    "Sources (SERIAL=SOURCE; lists inside a value separated by '/'):\n"
    "  sim:PROFILE[,index=N][,duration=S][,rate=HZ][,actual_rate=HZ][,seed=N][,quantize=0|1]"
    "[,lsb=X[,bits=16]]\n"
    "      a simulated unit (vg700, tactical, fog, mems-lab, mems-real)\n"
    "      e.g. --unit SN-1=sim:tactical,index=3,duration=3600\n"
    "  csv:FILE,rate=HZ[,axes=NAME:gyro/NAME:accel...][,counter=COL][,time=COL][,scale=F]"
    "[,temperature=COL][,AXIS=COL[:UNIT[:SCALE]]...]\n"
    "      a recording; AXIS=COL:UNIT reads an axis from its own column in its own unit (gyro "
    "deg/s, rad/s, mrad/s, deg/h, rpm; accel m/s^2, g, mg, ug), times SCALE\n"
    "      e.g. --unit SN-2=csv:imu.csv,rate=100,gx=wx:rad/s,ax=fx:g,temperature=temp_c\n"
    "  serial:DEVICE,protocol=text|xsens|crossbow[,rate=HZ][,duration=S][,baud=N][,parity=...]"
    "[,axes=...][,reconnect_timeout=S]\n"
    "      a live device; text: columns=NAME/NAME/...(_ skips)[,counter=COL][,temperature=COL]\n"
    "      e.g. --unit SN-3=serial:/dev/ttyUSB0,protocol=text,baud=115200,"
    "columns=gx/gy/gz,duration=3600\n"
    "  archive:DB,run=RUN_ID\n"
    "      a stored run replayed from its raw samples\n"
    "      e.g. --unit SN-4=archive:station.db,run=20261129T080030Z-station-1-SN-4\n"
    "  bag:FILE[,topic=/imu][,rate=HZ][,axes=gx/gy/gz/ax/ay/az]\n"
    "      a ROS 1 bag's sensor_msgs/Imu messages\n"
    "      e.g. --unit SN-5=bag:soak.bag,topic=/imu/data,rate=200";

// What a spec may take from the acquire process's other flags.
struct SourceDefaults {
  pb::TestPlan plan;      // its axes name CSV columns
  std::string lot;        // seeds simulated units
  double duration_s = 0;  // simulated duration
  double rate_hz = 0;     // simulated rate (0: the profile's)
  uint64_t seed = 0;
  int index = 0;  // simulated unit index in the lot
};

Result<std::unique_ptr<SampleSource>> MakeSource(const SourceSpec& spec,
                                                 const SourceDefaults& defaults);

// Whether a unit's source gives the plan's axes, in order, with their kinds
// (a plan without axes takes any); the error names the unit and both lists.
Status CheckSourceAxes(const std::string& serial, const SourceInfo& info, const pb::TestPlan& plan);

}  // namespace imuqual::acquire

#endif  // IMUQUAL_ACQUIRE_SOURCE_SPEC_H_
