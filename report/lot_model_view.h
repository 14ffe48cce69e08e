// The lot noise model of every axis of a lot (analyze/allan/lot_model.h),
// from the archived curve of each unit's latest run, and its tables for
// `imuqual lot --stats|--model`, `imuqual compare` and the report.
#ifndef IMUQUAL_REPORT_LOT_MODEL_VIEW_H_
#define IMUQUAL_REPORT_LOT_MODEL_VIEW_H_

#include <string>
#include <vector>

#include "analyze/allan/lot_model.h"
#include "report/allan_plots.h"
#include "report/table_writer.h"
#include "store/archive.h"

namespace imuqual::report {

struct AxisLotModel {
  std::string axis;
  pb::AxisKind kind = pb::GYRO;
  int curves = 0;  // units with a curve of this axis
  Result<allan::LotModel> model = Status::NotFound("no curve");
};

// Each unit's latest run in `lot`, in serial order. NotFound names the lot.
Result<std::vector<RunPlotData>> LoadLatestRuns(store::Archive& archive, const std::string& lot);

// One lot model per axis name, in the order the runs list their axes; an
// axis whose model cannot be made says why in `model`.
std::vector<AxisLotModel> ComputeLotModels(const std::vector<RunPlotData>& runs);

// One row per axis: the model, its adequacy, the datasheet figures with
// their sigmas (the lot-mean model's precision), the spread between units at the shortest
// and longest pooled tau, and the units inconsistent with the lot; `lot`
// fills a first column when not empty.
void AddLotModelRows(const std::string& lot, const std::vector<AxisLotModel>& models,
                     TableWriter* table);
TableWriter LotModelTable(bool with_lot);

// "; model of 7 units, left out as inconsistent with their lot: SN-8
// (every unit pooled: N+B+K, J-test p = 7.9e-05)", or "" when every unit
// is pooled.
std::string LeftOutNote(const allan::LotModel& model);

// One row per unit inconsistent with its lot on some axis.
TableWriter InconsistentUnitsTable(const std::vector<AxisLotModel>& models);

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_LOT_MODEL_VIEW_H_
