// LCM channel names of a station bus. The "5" is the message-contract
// version: a change to any lcmtypes/ struct or to the seal every message
// carries (common/bus_seal.h; 5: the authenticated seal) changes it, and the
// version bump keeps old and new processes on separate channels.
#ifndef IMUQUAL_COMMON_CHANNELS_H_
#define IMUQUAL_COMMON_CHANNELS_H_

#include <string>

namespace imuqual::channels {

inline constexpr char kRun[] = "IMUQUAL5_RUN";        // run_t heartbeats
inline constexpr char kAck[] = "IMUQUAL5_ACK";        // ack_t flow control
inline constexpr char kResend[] = "IMUQUAL5_RESEND";  // resend_t requests
inline constexpr char kStatus[] = "IMUQUAL5_STATUS";  // status_t per process
// acquire's status_t counter "reconnecting:<run id>" = 1: that run's serial
// device is gone and acquire is reconnecting (absent otherwise).
inline constexpr char kReconnectingCounterPrefix[] = "reconnecting:";

inline constexpr char kRawPrefix[] = "IMUQUAL5_RAW.";            // + unit serial: rate_batch_t
inline constexpr char kCurvePrefix[] = "IMUQUAL5_CURVE.";        // + unit serial: allan_curve_t
inline constexpr char kResultPrefix[] = "IMUQUAL5_RESULT.";      // + unit serial: unit_result_t
inline constexpr char kDecisionPrefix[] = "IMUQUAL5_DECISION.";  // + unit serial: decision_t

// Regular expressions (LCM anchors them) matching every unit's channel.
inline constexpr char kRawAll[] = "IMUQUAL5_RAW\\..*";
inline constexpr char kCurveAll[] = "IMUQUAL5_CURVE\\..*";
inline constexpr char kResultAll[] = "IMUQUAL5_RESULT\\..*";
inline constexpr char kDecisionAll[] = "IMUQUAL5_DECISION\\..*";

inline std::string Raw(const std::string& serial) { return kRawPrefix + serial; }
inline std::string Curve(const std::string& serial) { return kCurvePrefix + serial; }
inline std::string Result(const std::string& serial) { return kResultPrefix + serial; }
inline std::string Decision(const std::string& serial) { return kDecisionPrefix + serial; }

}  // namespace imuqual::channels

#endif  // IMUQUAL_COMMON_CHANNELS_H_
