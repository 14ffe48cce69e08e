// The plant archive's questions, timed: a lot's report data loaded and
// rendered on a fresh connection (the lot page's first view as served, its
// noise model section fetched after it, and the report as a file), a unit's
// history, the yield trend per week, a control chart per week, and a
// station agreement study, each p50 and p99 over repeated calls on the same
// archive: the plant's PostgreSQL, or one station's SQLite file, for
// comparison. Prints "name value unit" lines.
// Usage: plant_bench --db FILE|postgresql://... --label NAME [--golden LOT] [--iterations N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "analyze/judge/control_chart.h"
#include "report/control_chart_view.h"
#include "report/msa_view.h"
#include "report/report.h"
#include "report/yield_trend.h"
#include "store/archive.h"
#include "store/query.h"

namespace {

using namespace imuqual;

double Ms(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

void Time(const std::string& label, const std::string& name, int n,
          const std::function<bool(int)>& fn) {
  std::vector<double> ms;
  for (int i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    if (!fn(i)) {
      std::printf("%s_%s failed\n", label.c_str(), name.c_str());
      return;
    }
    ms.push_back(Ms(std::chrono::steady_clock::now() - t0));
  }
  std::sort(ms.begin(), ms.end());
  auto q = [&](double p) { return ms[std::min(ms.size() - 1, static_cast<size_t>(p * ms.size()))]; };
  std::printf("%s_%s_p50 %.1f ms\n%s_%s_p99 %.1f ms\n", label.c_str(), name.c_str(), q(0.5),
              label.c_str(), name.c_str(), q(0.99));
}

}  // namespace

int main(int argc, char** argv) {
  std::string db, label = "plant", golden;
  int iterations = 20;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--db") == 0) db = argv[i + 1];
    if (std::strcmp(argv[i], "--label") == 0) label = argv[i + 1];
    if (std::strcmp(argv[i], "--golden") == 0) golden = argv[i + 1];
    if (std::strcmp(argv[i], "--iterations") == 0) iterations = std::atoi(argv[i + 1]);
  }
  auto archive = store::Archive::Open(db, store::Archive::Mode::kRead);
  if (db.empty() || !archive.ok()) {
    std::fprintf(stderr, "plant_bench: --db needed (%s)\n",
                 archive.ok() ? "" : archive.status().message().c_str());
    return 2;
  }
  auto lots = store::QueryLots(**archive);
  auto runs = store::QueryRunVerdicts(**archive);
  if (!lots.ok() || lots->empty() || !runs.ok()) {
    std::fprintf(stderr, "plant_bench: no lots in %s\n", db.c_str());
    return 2;
  }
  std::printf("%s_runs %zu runs\n", label.c_str(), runs->size());
  std::vector<std::string> serials;
  for (size_t i = 0; i < runs->size(); i += std::max<size_t>(1, runs->size() / 97)) {
    serials.push_back((*runs)[i].unit);
  }
  // The served lot page's first view (imuqual serve: its noise model section
  // fetched by its script), then that section, then the report as a file
  // (the fits in it).
  Time(label, "lot_page_first_view", iterations, [&](int i) {
    auto fresh = store::Archive::Open(db, store::Archive::Mode::kRead);
    if (!fresh.ok()) return false;
    const std::string& lot = (*lots)[(static_cast<size_t>(i) * 37) % lots->size()].lot;
    auto data = report::LoadLotReport(**fresh, lot, report::LotReportLoad::kFirstView);
    report::LotReportOptions served;
    served.section_url = [&](const std::string& part) { return "/lot-section?part=" + part; };
    return data.ok() && !report::RenderLotReportHtml(*data, db, served).empty();
  });
  // Its deferred sections, each fetched by the page after it.
  for (const char* part : {"lot-model", "lot-plots", "unit-plots"}) {
    Time(label, std::string("lot_section_") + part, iterations, [&](int i) {
      auto fresh = store::Archive::Open(db, store::Archive::Mode::kRead);
      if (!fresh.ok()) return false;
      const std::string& lot = (*lots)[(static_cast<size_t>(i) * 37) % lots->size()].lot;
      auto data = report::LoadLotReport(**fresh, lot);
      return data.ok() && report::RenderLotSection(*data, part).ok();
    });
  }
  Time(label, "lot_report_file", iterations, [&](int i) {
    auto fresh = store::Archive::Open(db, store::Archive::Mode::kRead);
    if (!fresh.ok()) return false;
    const std::string& lot = (*lots)[(static_cast<size_t>(i) * 37) % lots->size()].lot;
    auto data = report::LoadLotReport(**fresh, lot);
    return data.ok() && !report::RenderLotReportHtml(*data, db).empty();
  });
  // Reading a lot's whole report data (what a report file and each section
  // read).
  Time(label, "lot_report_load", iterations, [&](int i) {
    auto fresh = store::Archive::Open(db, store::Archive::Mode::kRead);
    if (!fresh.ok()) return false;
    const std::string& lot = (*lots)[(static_cast<size_t>(i) * 37) % lots->size()].lot;
    return report::LoadLotReport(**fresh, lot).ok();
  });
  Time(label, "unit_history", iterations * 5, [&](int i) {
    auto rows = store::QueryUnitHistory(**archive, serials[static_cast<size_t>(i) % serials.size()]);
    return rows.ok() && !rows->empty();
  });
  Time(label, "yield_trend_week", iterations, [&](int) {
    auto r = store::QueryRunVerdicts(**archive);
    return r.ok() && !report::YieldTrend(*r, report::YieldBy::kWeek).empty();
  });
  Time(label, "control_chart_week", iterations, [&](int) {
    auto rows = store::QueryMeasurementHistory(**archive, "bias_instability", "gx");
    if (!rows.ok()) return false;
    return judge::MakeControlChart(report::ChartSubgroups(*rows, report::ChartBy::kWeek, "")).ok();
  });
  if (!golden.empty()) {
    Time(label, "msa", iterations, [&](int) {
      auto rows = store::QueryRunValues(**archive, golden);
      return rows.ok() && !report::StudyStations(*rows, {}).empty();
    });
  }
  return 0;
}
