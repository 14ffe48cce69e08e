// Station agreement (measurement system analysis, analyze/judge/msa.h) from
// the archive's values: a lot of golden units soaked on several stations,
// one study per judged measurement and axis, and its tables for the
// command line and the pages.
#ifndef IMUQUAL_REPORT_MSA_VIEW_H_
#define IMUQUAL_REPORT_MSA_VIEW_H_

#include <string>
#include <vector>

#include "analyze/judge/msa.h"
#include "report/table_writer.h"
#include "store/query.h"

namespace imuqual::report {

// Who the study's appraisers are: stations (reproducibility between
// stations), operators (between the people who mount and start the units),
// or each station and operator pair.
enum class Appraiser { kStation, kOperator, kStationOperator };
// "station", "operator", "station-operator".
Result<Appraiser> ParseAppraiser(const std::string& text);
std::string AppraiserName(Appraiser a);

struct MsaSelection {
  std::string measurement;  // "" = every measurement with a limit
  std::string axis;         // "" = every axis
  int trials = 0;           // 0: as many as every unit has on every station
  Appraiser appraiser = Appraiser::kStation;
};

struct MsaOutcome {
  std::string axis, measurement, unit;
  judge::MsaResult result;  // when `why_not` is empty
  std::string why_not;      // why no study could be made (a unit missing on a station, ...)
};

// One study per (axis, measurement): parts are the lot's units, appraisers
// its stations (or operators, or station and operator pairs: the
// selection's appraiser), trials each unit's first `trials` judged runs by
// each appraiser (oldest first).
std::vector<MsaOutcome> StudyStations(const std::vector<store::RunValueRow>& rows,
                                      const MsaSelection& selection);

// A row per study: the components, %GRR, ndc, the manual's reading.
TableWriter MsaTable(const std::vector<MsaOutcome>& outcomes,
                     Appraiser appraiser = Appraiser::kStation);
// A row per study and station: its offset from the fleet (also in % of the
// mean) with its 95 % interval, and whether it differs.
TableWriter MsaOffsetsTable(const std::vector<MsaOutcome>& outcomes,
                            Appraiser appraiser = Appraiser::kStation);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_MSA_VIEW_H_
