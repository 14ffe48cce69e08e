// Query benchmarks on a production history (imuqual-history-gen): the lot
// summary (`imuqual lot LOT --stats`: unit rows and statistics) and the lot
// comparison (`imuqual compare A B`), in-process, on a cold-started archive
// connection per iteration so each figure is what one command pays.
// Usage: query_bench --db HISTORY.db [benchmark flags]
#include <cstring>
#include <string>

#include "bench/bench_summary.h"
#include "report/lot_statistics.h"
#include "store/archive.h"
#include "store/query.h"

namespace {

using namespace imuqual;

std::string g_db;
std::vector<std::string> g_lots;

void LotSummary(benchmark::State& state) {
  size_t i = 0;
  for (auto _ : state) {
    auto archive = store::Archive::Open(g_db, store::Archive::Mode::kRead);
    const std::string& lot = g_lots[i++ % g_lots.size()];
    store::AxisRowFilter f;
    f.lot = lot;
    auto units = store::QueryAxisRows(**archive, f);
    auto rows = store::QueryLotMeasurements(**archive, lot);
    auto stats = report::ComputeLotStatistics(*rows);
    benchmark::DoNotOptimize(units->size() + stats.size());
  }
}
BENCHMARK(LotSummary)->Unit(benchmark::kMillisecond)->Iterations(20)->Repetitions(3);

void LotCompare(benchmark::State& state) {
  size_t i = 0;
  for (auto _ : state) {
    auto archive = store::Archive::Open(g_db, store::Archive::Mode::kRead);
    const std::string& a = g_lots[i++ % g_lots.size()];
    const std::string& b = g_lots[(i * 37) % g_lots.size()];
    auto ra = store::QueryLotMeasurements(**archive, a);
    auto rb = store::QueryLotMeasurements(**archive, b);
    auto c = report::CompareLots(report::ComputeLotStatistics(*ra),
                                 report::ComputeLotStatistics(*rb), 0.05);
    benchmark::DoNotOptimize(c.size());
  }
}
BENCHMARK(LotCompare)->Unit(benchmark::kMillisecond)->Iterations(20)->Repetitions(3);

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], "--db") == 0) g_db = argv[i + 1];
  }
  auto archive = store::Archive::Open(g_db, store::Archive::Mode::kRead);
  if (g_db.empty() || !archive.ok()) {
    std::fprintf(stderr, "query_bench: --db HISTORY.db needed (%s)\n",
                 archive.ok() ? "" : archive.status().message().c_str());
    return 2;
  }
  auto lots = store::QueryLots(**archive);
  for (const store::LotRow& l : *lots) g_lots.push_back(l.lot);
  if (g_lots.empty()) return 2;
  std::vector<char*> args = {argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--db") == 0) {
      ++i;
      continue;
    }
    args.push_back(argv[i]);
  }
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  bench::SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  bench::PrintFigure("lot_summary_s",
                     reporter.BestRealSeconds("LotSummary/iterations:20/repeats:3"), "s");
  bench::PrintFigure("lot_compare_s",
                     reporter.BestRealSeconds("LotCompare/iterations:20/repeats:3"), "s");
  bench::PrintFigure("history_lots", static_cast<double>(g_lots.size()), "lots");
  return 0;
}
