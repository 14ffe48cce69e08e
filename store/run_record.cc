#include "store/run_record.h"

#include "store/outcome.h"

namespace imuqual::store {

pb::RunRecord BuildRunRecord(const RunInfo& run, const ResultRecord& result, int64_t gap_ranges) {
  pb::RunRecord rec;
  rec.set_run_id(run.run_id);
  rec.set_unit_serial(run.serial);
  rec.set_lot(run.lot);
  rec.set_station(run.station);
  rec.set_slot(run.slot);
  rec.set_operator_name(run.operator_name);
  rec.set_software_version(run.software_version);
  rec.set_source(run.source);
  rec.set_start_utime(run.start_utime);
  rec.set_end_utime(run.end_utime.value_or(0));
  rec.set_state(run.state);
  rec.mutable_plan()->ParseFromString(run.plan);
  rec.set_plan_sha256(run.plan_sha256);
  rec.set_bus_auth(run.bus_auth);
  for (const pb::Measurement& m : result.measurements) *rec.add_measurements() = m;
  rec.set_verdict(OutcomeFromText(result.verdict));
  for (const std::string& reason : result.reasons) rec.add_reasons(reason);
  rec.mutable_gaps()->set_samples(result.samples);
  rec.mutable_gaps()->set_gap_samples(result.gap_samples);
  rec.mutable_gaps()->set_invalid_samples(result.invalid_samples);
  rec.mutable_gaps()->set_gap_ranges(gap_ranges);
  return rec;
}

}  // namespace imuqual::store
