#include "store/records.h"

#include <cmath>

#include "store/chunk_codec.h"
#include "store/outcome.h"

namespace imuqual::store {

const char* StateName(int8_t run_state) {
  switch (run_state) {
    case imuqual::run_t::STATE_COMPLETE: return "complete";
    case imuqual::run_t::STATE_ABORTED: return "aborted";
    case imuqual::run_t::STATE_INCOMPLETE: return "incomplete";
    default: return "running";
  }
}

int8_t StateCode(const std::string& state) {
  if (state == "complete") return imuqual::run_t::STATE_COMPLETE;
  if (state == "aborted") return imuqual::run_t::STATE_ABORTED;
  if (state == "incomplete") return imuqual::run_t::STATE_INCOMPLETE;
  return imuqual::run_t::STATE_RUNNING;
}

imuqual::run_t MessageFromRunInfo(const RunInfo& info) {
  imuqual::run_t r;
  r.host_utime = 0;
  r.run_id = info.run_id;
  r.unit_serial = info.serial;
  r.lot = info.lot;
  r.station = info.station;
  r.slot = info.slot;
  r.operator_name = info.operator_name;
  r.source = info.source;
  r.software_version = info.software_version;
  r.start_utime = info.start_utime;
  r.nominal_rate_hz = info.nominal_rate_hz;
  r.num_axes = static_cast<int8_t>(info.axes.size());
  for (const AxisInfo& a : info.axes) {
    r.axis_names.push_back(a.name);
    r.axis_kinds.push_back(a.kind == pb::ACCEL ? imuqual::rate_batch_t::KIND_ACCEL
                                               : imuqual::rate_batch_t::KIND_GYRO);
  }
  r.plan_size = static_cast<int32_t>(info.plan.size());
  r.plan.assign(info.plan.begin(), info.plan.end());
  r.plan_sha256 = info.plan_sha256;
  r.truth_size = static_cast<int32_t>(info.truth.size());
  r.truth.assign(info.truth.begin(), info.truth.end());
  r.state = StateCode(info.state);
  r.last_seq = info.last_seq;
  r.samples_published = info.samples_announced;
  r.first_sample = info.first_sample;
  r.end_sample = info.end_sample;
  r.announcer = "store";
  r.retained_first_seq = 0;
  r.end_reason = info.end_reason;
  r.revision = static_cast<int16_t>(info.revision);
  r.planned_s = 0;  // the archive does not keep it: unknown (for progress only)
  return r;
}

Result<imuqual::rate_batch_t> BatchFromChunk(const RunInfo& info, const ChunkRecord& c) {
  auto data = DecodeChunk(c.data, c.codec);
  if (!data.ok()) return data.status();
  if (data->num_axes != static_cast<int>(info.axes.size())) {
    return Status::Corruption("chunk " + std::to_string(c.seq) + " of " + info.run_id +
                              " has " + std::to_string(data->num_axes) + " axes");
  }
  imuqual::rate_batch_t b;
  b.host_utime = c.host_utime;
  b.sample_utime = c.sample_utime;
  b.run_id = info.run_id;
  b.unit_serial = info.serial;
  b.seq = c.seq;
  b.first_sample = c.first_sample;
  b.nominal_rate_hz = info.nominal_rate_hz;
  b.num_axes = static_cast<int8_t>(info.axes.size());
  for (const AxisInfo& a : info.axes) {
    b.axis_names.push_back(a.name);
    b.axis_kinds.push_back(a.kind == pb::ACCEL ? imuqual::rate_batch_t::KIND_ACCEL
                                               : imuqual::rate_batch_t::KIND_GYRO);
  }
  b.num_samples = static_cast<int16_t>(data->num_samples);
  for (int a = 0; a < data->num_axes; ++a) {
    const float* begin = data->samples.data() + static_cast<size_t>(a) * data->num_samples;
    b.samples.emplace_back(begin, begin + data->num_samples);
  }
  b.num_flagged = static_cast<int16_t>(data->flags.size());
  for (const SampleFlag& f : data->flags) {
    b.flagged_sample.push_back(static_cast<int16_t>(f.sample));
    b.flagged_axis.push_back(static_cast<int8_t>(f.axis));
    b.flagged_bits.push_back(static_cast<int8_t>(f.bits));
  }
  b.has_temperature = c.temperature_c.has_value();
  b.temperature_c = static_cast<float>(c.temperature_c.value_or(0.0));
  return b;
}

RunInfo RunInfoFromMessage(const imuqual::run_t& r) {
  RunInfo info;
  info.run_id = r.run_id;
  info.serial = r.unit_serial;
  info.lot = r.lot;
  info.station = r.station;
  info.slot = r.slot;
  info.operator_name = r.operator_name;
  info.source = r.source;
  info.software_version = r.software_version;
  info.start_utime = r.start_utime;
  info.nominal_rate_hz = r.nominal_rate_hz;
  for (int i = 0; i < r.num_axes; ++i) {
    info.axes.push_back({r.axis_names[i], r.axis_kinds[i] == imuqual::rate_batch_t::KIND_ACCEL
                                              ? pb::ACCEL
                                              : pb::GYRO});
  }
  info.plan.assign(r.plan.begin(), r.plan.end());
  info.plan_sha256 = r.plan_sha256;
  info.truth.assign(r.truth.begin(), r.truth.end());
  info.state = StateName(r.state);
  info.last_seq = r.last_seq;
  info.samples_announced = r.samples_published;
  info.first_sample = r.first_sample;
  info.end_sample = r.end_sample;
  info.end_reason = r.end_reason;
  if (r.state != imuqual::run_t::STATE_RUNNING) info.end_utime = r.host_utime;
  return info;
}

ChunkRecord ChunkFromBatch(const imuqual::rate_batch_t& b, std::vector<double>* scales) {
  ChunkData d;
  d.num_axes = b.num_axes;
  d.num_samples = b.num_samples;
  d.samples.reserve(static_cast<size_t>(b.num_axes) * b.num_samples);
  for (const std::vector<float>& axis : b.samples) d.samples.insert(d.samples.end(), axis.begin(), axis.end());
  for (int i = 0; i < b.num_flagged; ++i) {
    d.flags.push_back({static_cast<uint16_t>(b.flagged_sample[i]),
                       static_cast<uint8_t>(b.flagged_axis[i]),
                       static_cast<uint8_t>(b.flagged_bits[i])});
  }
  ChunkRecord c;
  c.seq = b.seq;
  c.first_sample = b.first_sample;
  c.num_samples = b.num_samples;
  c.host_utime = b.host_utime;
  c.sample_utime = b.sample_utime;
  if (b.has_temperature) c.temperature_c = b.temperature_c;
  EncodedChunk encoded = EncodeChunkCompact(d, scales);
  c.codec = encoded.codec;
  c.data = std::move(encoded.data);
  return c;
}

CurveRecord CurveFromMessage(const imuqual::allan_curve_t& msg) {
  CurveRecord rec;
  rec.axis = msg.axis;
  rec.curve.deviation = allan::ParseDeviation(msg.estimator).value_or(allan::Deviation::kOadev);
  rec.curve.ci = allan::ParseCiMethod(msg.ci_method).value_or(allan::CiMethod::kNone);
  rec.curve.tau0_s = msg.tau0_s;
  rec.samples = msg.samples;
  rec.valid_samples = msg.valid_samples;
  rec.computed_utime = msg.host_utime;
  for (int i = 0; i < msg.num_points; ++i) {
    allan::CurvePoint p;
    p.m = msg.m[i];
    p.tau_s = msg.tau_s[i];
    p.dev = msg.dev[i];
    p.lo = msg.lo[i];
    p.hi = msg.hi[i];
    p.edf = msg.edf[i];
    p.n = msg.n_terms[i];
    p.stride = msg.stride[i];
    if (msg.alpha[i] != imuqual::allan_curve_t::NO_ALPHA) {
      p.alpha = msg.alpha[i];
      p.alpha_inherited = msg.alpha_inherited[i];
    }
    rec.curve.points.push_back(p);
  }
  return rec;
}

namespace {
// measurement_t's OUTCOME_*, QUALIFIER_* and RULE_* codes are the numbers
// of pb::Outcome, pb::Qualifier and pb::Limit::DecisionRule; an unknown code
// reads as unset.
pb::Qualifier QualifierFromCode(int8_t code) {
  return pb::Qualifier_IsValid(code) ? static_cast<pb::Qualifier>(code) : pb::QUALIFIER_NONE;
}
pb::Limit::DecisionRule RuleFromCode(int8_t code) {
  return pb::Limit::DecisionRule_IsValid(code) ? static_cast<pb::Limit::DecisionRule>(code)
                                               : pb::Limit::RULE_DEFAULT;
}
}  // namespace

ResultRecord ResultFromMessage(const imuqual::unit_result_t& msg) {
  ResultRecord r;
  r.verdict = OutcomeText(OutcomeFromNumber(msg.verdict));
  r.reasons = msg.reasons;
  r.samples = msg.samples;
  r.gap_samples = msg.gap_samples;
  r.invalid_samples = msg.invalid_samples;
  r.axis_invalid_samples = msg.axis_invalid_samples;
  r.result_utime = msg.host_utime;
  r.revision = msg.revision;
  r.last_seq = msg.last_seq;
  r.gap_batches = msg.gap_batches;
  for (const imuqual::measurement_t& m : msg.measurements) {
    pb::Measurement pm;
    pm.set_axis(m.axis);
    pm.set_name(m.name);
    pm.set_value(m.value);
    if (!std::isnan(m.uncertainty)) pm.set_uncertainty(m.uncertainty);
    pm.set_unit(m.unit);
    if (!std::isnan(m.low)) pm.set_low(m.low);
    if (!std::isnan(m.high)) pm.set_high(m.high);
    if (!std::isnan(m.marginal_low)) pm.set_marginal_low(m.marginal_low);
    if (!std::isnan(m.marginal_high)) pm.set_marginal_high(m.marginal_high);
    pm.set_outcome(OutcomeFromNumber(m.outcome));
    pm.set_note(m.note);
    pm.set_uncertainty_method(m.uncertainty_method);
    pm.set_qualifier(QualifierFromCode(m.qualifier));
    pm.set_decision_rule(RuleFromCode(m.decision_rule));
    if (!std::isnan(m.guard_band)) pm.set_guard_band(m.guard_band);
    r.measurements.push_back(std::move(pm));
  }
  return r;
}

}  // namespace imuqual::store
