// A lot's qualification report (`imuqual report`, the end of `imuqual run`) as one self-contained
// HTML file (inline CSS, inline SVG plots, a few lines of inline script to sort the tables; no
// external resource of any kind), readable in any browser and printable.
//
// Content, for each unit's latest run in the lot:
//  - the lot header: lot, plan(s), units, runs, PASS / MARGINAL / FAIL
//    counts, yield = (PASS + MARGINAL) / judged, first and last start (UTC);
//  - the units needing attention (FAIL, then MARGINAL) with their reasons;
//  - per unit and axis: ARW/VRW, bias instability (curve minimum and IEEE B),
//    tau at the minimum, RRW, gap samples, the axis and unit verdicts; each
//    value coloured by its own judgement; one table per axis kind, units in
//    the headers;
//  - the lot statistics per axis and measurement (n, mean, sd, min, max,
//    limits, yield, Cpk/Cpu/Cpl), judged measurements first;
//  - the Allan plots: the lot overlay per axis, and each FAIL or MARGINAL
//    unit's own plot (see plot_command.h).
//
// For programs reading the page: visible numbers are rounded for people,
// and every numeric cell carries its full-precision value in data-v (the shortest text that reads
// back exactly, empty for none). Rows are identified by data-run/data-serial/data-axis (results)
// and data-axis/data-name/data-unit (statistics; axis "" = run level; data-unit the values' unit),
// cells by data-m (measurement) or data-stat. Every text from the archive is
// HTML-escaped.
#ifndef IMUQUAL_REPORT_REPORT_H_
#define IMUQUAL_REPORT_REPORT_H_

#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "common/status.h"
#include "report/allan_plots.h"
#include "report/early_decisions.h"
#include "report/lot_statistics.h"
#include "store/archive.h"
#include "store/query.h"

namespace imuqual::report {

// Everything a lot's report shows, read from the archive once: the report
// is rendered from these values without a database. Move-only (by_key
// points into measurements).
struct LotReportData {
  LotReportData() = default;
  LotReportData(LotReportData&&) = default;
  LotReportData& operator=(LotReportData&&) = default;
  LotReportData(const LotReportData&) = delete;
  LotReportData& operator=(const LotReportData&) = delete;

  store::LotRow lot;
  std::vector<store::AxisRow> rows;  // latest run per unit, per axis
  std::vector<store::MeasurementRow> measurements;
  using MeasurementKey = std::tuple<std::string, std::string, std::string>;  // run, axis, name
  std::map<MeasurementKey, const store::MeasurementRow*> by_key;
  std::vector<MeasurementStats> stats;
  std::vector<RunPlotData> runs;  // one per unit, in the rows' order
  std::vector<store::RetestRow> retests;
  EarlyDecisionSummary early;  // every judged run with early decisions
  // The raw-sample plot of each unit shown on its own (FAIL, INCONCLUSIVE,
  // MARGINAL ...), by run id: its SVG, or why it could not be drawn.
  struct Series {
    std::string svg;
    Status status;
  };
  std::map<std::string, Series> series;
  // The dynamic Allan deviation of the same units, one SVG per axis, or why
  // it could not be drawn.
  struct DynamicAllanPlots {
    std::vector<std::string> svgs;
    Status status;
  };
  std::map<std::string, DynamicAllanPlots> davar;
};

// Reads the lot's report data. NotFound names the lot when the archive has
// no run of it.
// What of a lot LoadLotReport reads: everything (a report file, a deferred
// section), or what a served page's first view shows (no curves, no raw
// samples: its plots are fetched after it).
enum class LotReportLoad { kAll, kFirstView };
Result<LotReportData> LoadLotReport(store::Archive& archive, const std::string& lot,
                                    LotReportLoad load = LotReportLoad::kAll);

struct LotReportOptions {
  // Unset (default): every section is in the report (a file stands alone).
  // Set: the sections that take the most time (the lot noise models, the
  // lot's Allan plots, the flagged units' plots and raw samples) are left
  // to the report's script, which fetches each from section_url(PART)
  // (RenderLotSection, served): a served page's first view waits for none
  // of them.
  std::function<std::string(const std::string& part)> section_url;
  // Served: the site's navigation (HTML, trusted), first in the page, so a
  // lot page leads back to the lot list and the other pages; "" for a file.
  std::string site_navigation;
};

// The report's HTML from its data; `archive_label` is how the page names
// the archive (e.g. its path).
std::string RenderLotReportHtml(const LotReportData& data, const std::string& archive_label,
                                const LotReportOptions& options = {});

// The report's lot noise model section alone (an HTML fragment): a fit per
// axis of the lot's curves.
std::string RenderLotModelSection(const LotReportData& data);

// One deferred section of the report (an HTML fragment): "lot-model",
// "lot-plots" or "unit-plots" ("" when no unit needs a look). NotFound for
// another part.
Result<std::string> RenderLotSection(const LotReportData& data, const std::string& part);

// LoadLotReport, then RenderLotReportHtml. NotFound names the lot when the archive has no run of
// it. `archive_label` is how the page names the archive (e.g. its path).
Result<std::string> BuildLotReportHtml(store::Archive& archive, const std::string& lot,
                                       const std::string& archive_label,
                                       const LotReportOptions& options = {});

// The report's only script (sortable tables), which BuildLotReportHtml puts
// inline as "<script>" + LotReportScript() + "</script>": a server whose
// policy forbids inline scripts serves it as a file instead (web/).
std::string_view LotReportScript();

}  // namespace imuqual::report

#endif  // IMUQUAL_REPORT_REPORT_H_
